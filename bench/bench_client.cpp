// bench_client: the whole client (VIO on every frame, stereo depth, temporal filter, GICP to
// the prior and fusion on keyframes) on an EuRoC-layout sequence, e.g. the paper preset
// (800x450 at 30 Hz). Runs the pipeline as shipped (frames decoded and VIO-tracked on their
// own thread ahead of the estimator) beside the baseline without that thread (the odometry
// thread decodes and tracks each frame itself; keyframe depth stays on its own thread in
// both), same input, one after the other in one process.
// Reports per run: wall time against the sequence's duration (real-time factor: > 1 keeps
// up), process CPU, per-stage seconds, and the ATE of VIO-alone and fused trajectories so a
// speed-up is not bought with accuracy.
//
// Wall times are the figure here (the question is keeping up with the camera on 2 cores);
// on a shared machine they include waiting for a CPU, so run it on an otherwise idle one.
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "mapdelta/client/config.hpp"
#include "mapdelta/client/pipeline.hpp"
#include "mapdelta/client/prior_source.hpp"
#include "mapdelta/client/vio_odometry_source.hpp"
#include "mapdelta/common/ate.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/log.hpp"
#include "sequence_bench_args.hpp"

namespace {

const char* kDescription =
    "Whole-client benchmark on a sequence: the shipped pipeline structure beside the baseline\n"
    "(bench/README.md).";

double ProcessCpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

struct Row {
  std::string name;
  double wall_s = 0, cpu_s = 0, ate_vio = -1, ate_fused = -1;
  mapdelta::client::PipelineResult result;
};

Row Run(const std::string& name, const std::string& sequence_dir, const std::string& prior_path,
        int max_frames, bool decode_ahead) {
  using namespace mapdelta;
  using namespace mapdelta::client;
  const ClientConfig config;
  const StereoInput input(ReadEurocSequence(sequence_dir));
  const EurocSequence& seq = input.sequence();
  VioOdometrySource odometry(input, config.vio);
  std::unique_ptr<PriorSource> prior;
  if (!prior_path.empty())
    prior = std::make_unique<FilePriorSource>(prior_path, config.registration.prior_voxel_m);
  PipelineInputs in;
  in.sequence_dir = sequence_dir;
  in.odometry = &odometry;
  in.prior = prior.get();
  in.max_frames = max_frames;
  in.decode_ahead = decode_ahead;
  std::fprintf(stderr, "%s: running\n", name.c_str());
  Row row;
  row.name = name;
  const double cpu0 = ProcessCpuSeconds();
  const auto wall0 = std::chrono::steady_clock::now();
  row.result = RunPipeline(config, in);
  row.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  row.cpu_s = ProcessCpuSeconds() - cpu0;
  if (!seq.groundtruth.empty()) {
    if (row.result.vio_T_map_body.size() >= 3)
      row.ate_vio = ComputeAte(seq.groundtruth, row.result.vio_T_map_body).rmse;
    if (row.result.fused_T_map_body.size() >= 3)
      row.ate_fused = ComputeAte(seq.groundtruth, row.result.fused_T_map_body).rmse;
  }
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  mapdelta::bench::SequenceBenchArgs args;
  if (auto exit_code = mapdelta::bench::ParseSequenceBenchArgs(argc, argv, "bench_client",
                                                               kDescription, true, &args)) {
    return *exit_code;
  }
  const std::string& sequence = args.sequence;
  mapdelta::log::SetLevel(mapdelta::log::Level::kWarn);
  try {
    std::string prior = args.prior.value_or("");
    if (!args.prior) {
      const std::string guess = sequence + "/../../scenes/original/cloud.pcd";
      if (std::FILE* f = std::fopen(guess.c_str(), "rb")) {
        std::fclose(f);
        prior = guess;
      }
    }
    const auto seq = mapdelta::ReadEurocSequence(sequence);
    const auto frames = seq.StereoFrames();
    const double rate = mapdelta::bench::StereoFrameRate(seq, sequence);
    const double seconds = args.seconds;
    const bool baseline = args.baseline;
    int max_frames = 0;
    if (seconds > 0) max_frames = static_cast<int>(seconds * rate) + 1;
    const int n = max_frames > 0 ? std::min<int>(max_frames, static_cast<int>(frames.size()))
                                 : static_cast<int>(frames.size());
    const double duration_s = (n - 1) / rate;
    std::printf("bench_client: %s, %dx%d at %.1f Hz, %d frames = %.1f s, prior %s\n",
                sequence.c_str(), seq.cam0.intrinsics.width, seq.cam0.intrinsics.height, rate, n,
                duration_s, prior.empty() ? "none" : prior.c_str());
    std::vector<Row> rows;
    rows.push_back(Run("pipelined", sequence, prior, max_frames, true));
    if (baseline) rows.push_back(Run("baseline", sequence, prior, max_frames, false));
    std::printf("%-10s %8s %8s %7s %9s %9s %9s\n", "structure", "wall_s", "cpu_s", "rt",
                "keyframes", "ate_vio", "ate_fused");
    for (const auto& r : rows) {
      std::printf("%-10s %8.1f %8.1f %7.2f %9zu %9.3f %9.3f\n", r.name.c_str(), r.wall_s, r.cpu_s,
                  duration_s / r.wall_s, r.result.keyframes, r.ate_vio, r.ate_fused);
    }
    if (rows.size() == 2)
      std::printf("speed-up (wall, baseline / pipelined): %.2fx\n",
                  rows[1].wall_s / rows[0].wall_s);
    std::printf("(rt = sequence duration / wall time: >= 1 keeps up with the camera)\n");
    for (const auto& r : rows) {
      std::printf(
          "stages of %s (wall seconds summed per stage; stages overlap on their threads):\n",
          r.name.c_str());
      for (const auto& s : r.result.timing)
        std::printf("  %-24s %8.2f s %6zu calls\n", s.stage.c_str(), s.seconds, s.calls);
    }
  } catch (const std::exception& e) {
    std::cerr << "bench_client: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
