// Simulator throughput: Embree BVH vs brute-force box tests for the same renders (ratio), and the
// time to generate one `paper` sequence, measured on the first N stereo frames and extrapolated.
// usage: bench_sim [--frames 120] [--threads 2]
#include <sys/resource.h>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "mapdelta/common/cli.hpp"
#include "mapdelta/sim/dataset_writer.hpp"
#include "mapdelta/sim/generator.hpp"
#include "mapdelta/sim/raycaster.hpp"
#include "mapdelta/sim/renderer.hpp"

namespace {

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// CPU seconds used by this process so far (user + system): unlike wall time, it does not grow
// when other processes compete for the cores.
double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace mapdelta;
  using namespace mapdelta::sim;
  uint64_t frames = 120;
  int threads = 2;
  cli::Parser parser(
      "bench_sim",
      "Embree vs brute-force render time on the paper scene, and one sequence's stages.");
  parser.Option("frames", &frames, "views to render").Option("threads", &threads, "render threads");
  if (const auto exit_code = cli::ParseMain(parser, argc, argv, [&] {
        if (frames < 1 || threads < 1)
          cli::FailUsage(parser.program(), "--frames and --threads: expected >= 1");
      })) {
    return *exit_code;
  }
  SimConfig c = PresetConfig("paper");
  c.threads = threads;
  auto t0 = std::chrono::steady_clock::now();
  const Scenes scenes = BuildScenes(c);
  const SequencePlan plan = PlanSequence(c, scenes, "S1_01");
  size_t boxes = 0;
  for (const Object& o : scenes.s1.scene.objects) boxes += o.boxes.size();
  std::printf("paper scene: %zu objects, %zu boxes; S1_01 %.1f s, %.0f m (plan %.3f s)\n",
              scenes.s1.scene.objects.size(), boxes, plan.duration_s, plan.length_m, Seconds(t0));

  // 1. Ray casting backends side by side, one thread, same views.
  PinholeCamera cam;
  cam.width = c.width;
  cam.height = c.height;
  cam.fx = c.fx;
  cam.fy = c.fy;
  cam.cx = c.cx;
  cam.cy = c.cy;
  t0 = std::chrono::steady_clock::now();
  const EmbreeCaster embree(scenes.s1.scene);
  std::printf("embree BVH build: %.1f ms\n", 1e3 * Seconds(t0));
  const BruteForceCaster brute(scenes.s1.scene);
  const int views = 4;
  double t_embree = 0, t_brute = 0;
  for (int i = 0; i < views; ++i) {
    const SE3 T =
        plan.trajectory.Evaluate(plan.duration_s * (i + 0.5) / views).T_map_body * BodyToCam0();
    t0 = std::chrono::steady_clock::now();
    const RenderedView a = RenderView(scenes.s1.scene, embree, cam, T, {});
    t_embree += Seconds(t0);
    t0 = std::chrono::steady_clock::now();
    const RenderedView b = RenderView(scenes.s1.scene, brute, cam, T, {});
    t_brute += Seconds(t0);
    size_t differ = 0;
    for (size_t p = 0; p < a.depth.size(); ++p)
      differ += std::abs(a.depth[p] - b.depth[p]) > 1e-3f * b.depth[p];
    std::printf("  view %d: %zu of %zu pixels differ in depth by > 0.1%% between backends\n", i,
                differ, a.depth.size());
  }
  const double px = static_cast<double>(views) * cam.width * cam.height;
  std::printf(
      "render %dx%d, 1 thread: embree %.1f ms/view (%.2f Mpx/s), brute force %.1f ms/view; "
      "speed-up %.1fx\n",
      cam.width, cam.height, 1e3 * t_embree / views, px / t_embree * 1e-6, 1e3 * t_brute / views,
      t_brute / t_embree);

  // 2. One paper sequence: the first `frames` stereo pairs written to disk, then extrapolated.
  const auto dir = std::filesystem::temp_directory_path() / "mapdelta_bench_sim";
  std::filesystem::remove_all(dir);
  t0 = std::chrono::steady_clock::now();
  const double cpu0 = CpuSeconds();
  GenerateSequence(c, scenes, "S1_01", dir.string(), nullptr, frames);
  const double t_seq = Seconds(t0), cpu = CpuSeconds() - cpu0;
  const double total_frames = std::floor(plan.duration_s * c.cam_rate_hz) + 1;
  std::printf(
      "S1_01 (%d threads): %zu stereo pairs in %.1f s = %.1f ms/pair -> full sequence "
      "(%.0f pairs) extrapolated %.1f min\n",
      threads, frames, t_seq, 1e3 * t_seq / frames, total_frames,
      t_seq / frames * total_frames / 60.0);
  std::printf(
      "  CPU time %.1f s = %.1f ms/pair; on %d otherwise idle cores the full sequence would take "
      "about %.1f min\n",
      cpu, 1e3 * cpu / frames, threads, cpu / frames * total_frames / threads / 60.0);
  std::filesystem::remove_all(dir);
  return 0;
}
