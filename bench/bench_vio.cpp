// bench_vio: the stereo-inertial odometry (client/vio) on a prefix of an EuRoC-layout
// sequence (e.g. paper preset, 800x450 at 30 Hz): the current configuration against session
// 4's (200 features, full window solves on every frame, gauge in the prior) and session 1's
// (that plus autodiff reprojection Jacobians), side by side. Reports per configuration: VIO
// time per frame (wall and the calling thread's CPU, image decoding excluded), frames/s
// against the camera rate (ratio to real time),
// per-stage wall ms, and ATE, so speed-ups are not bought with accuracy.
//
// On a shared machine wall times include waiting for a CPU; the thread-CPU figures are the
// ones to compare (the VIO runs on one thread here).
#include <time.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "mapdelta/common/ate.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/vio/odometry.hpp"
#include "sequence_bench_args.hpp"

namespace {

const char* kUsage =
    "usage: bench_vio --sequence DIR [--seconds S] [--no-baseline]\n"
    "  --sequence DIR  EuRoC-layout sequence (e.g. /work/data/paper-small-s1/sequences/S1_01)\n"
    "  --seconds S     prefix of the sequence to run (default 20)\n"
    "  --no-baseline   skip the session-1 configuration\n";

double ThreadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

struct Row {
  std::string name;
  int frames = 0, resets = 0;
  double seq_s = 0, wall_ms = 0, cpu_ms = 0, ate = -1;
  mapdelta::vio::StageTimes stages;
};

Row Run(const std::string& name, const mapdelta::EurocSequence& seq,
        const mapdelta::vio::VioConfig& config, double seconds) {
  using namespace mapdelta;
  vio::StereoInertialOdometry odo(config, seq.cam0, seq.cam1, seq.imu);
  const auto frames = seq.StereoFrames();
  Row row;
  row.name = name;
  Trajectory estimate;
  size_t imu_index = 0;
  const auto& imu = seq.imu_samples;
  for (size_t i = 0; i < frames.size(); ++i) {
    const auto& f = frames[i];
    if (1e-9 * static_cast<double>(f.t_ns - frames.front().t_ns) > seconds) break;
    while (imu_index < imu.size() && imu[imu_index].t_ns <= f.t_ns) odo.AddImu(imu[imu_index++]);
    if (imu_index < imu.size()) odo.AddImu(imu[imu_index]);
    const cv::Mat left = cv::imread(f.left_path, cv::IMREAD_GRAYSCALE);
    const cv::Mat right = cv::imread(f.right_path, cv::IMREAD_GRAYSCALE);
    if (left.empty() || right.empty()) throw Error(ErrorCode::kIo, f.left_path + ": cannot read");
    const auto wall0 = std::chrono::steady_clock::now();
    const double cpu0 = ThreadCpuMs();
    const auto e = odo.AddStereoFrame(f.t_ns, {left.cols, left.rows, static_cast<int>(left.step), left.data},
                                      {right.cols, right.rows, static_cast<int>(right.step), right.data});
    row.cpu_ms += ThreadCpuMs() - cpu0;
    row.wall_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - wall0).count();
    row.stages += e.times;
    ++row.frames;
    if (e.reset) ++row.resets;
    if (e.initialized) estimate.push_back({e.t_ns, e.T_world_body});
    row.seq_s = 1e-9 * static_cast<double>(f.t_ns - frames.front().t_ns);
    if (row.frames % 100 == 0) std::fprintf(stderr, "\r%s: frame %d", name.c_str(), row.frames);
  }
  std::fprintf(stderr, "\n");
  if (!seq.groundtruth.empty() && estimate.size() >= 3) row.ate = ComputeAte(seq.groundtruth, estimate).rmse;
  return row;
}

void Print(const Row& r, double cam_rate_hz) {
  const double n = std::max(1, r.frames);
  const double budget_ms = 1e3 / cam_rate_hz;
  std::printf("%-10s %6d %8.2f %8.2f %9.1f %9.2f %9.2f %8.2f %8.2f %8.2f %8.2f %7.3f %6d\n",
              r.name.c_str(), r.frames, r.cpu_ms / n, r.wall_ms / n, 1e3 * n / r.cpu_ms,
              budget_ms / (r.cpu_ms / n), budget_ms / (r.wall_ms / n), r.stages.frontend_ms / n,
              r.stages.optimization_ms / n, r.stages.marginalization_ms / n,
              r.stages.covariance_ms / n, r.ate, r.resets);
}

}  // namespace

int main(int argc, char** argv) {
  mapdelta::bench::SequenceBenchArgs args;
  args.seconds = 20;
  if (auto exit_code = mapdelta::bench::ParseSequenceBenchArgs(argc, argv, "bench_vio", kUsage, false, &args)) {
    return *exit_code;
  }
  const std::string& sequence = args.sequence;
  const double seconds = args.seconds;
  const bool baseline = args.baseline;
  mapdelta::log::SetLevel(mapdelta::log::Level::kWarn);
  try {
    const auto seq = mapdelta::ReadEurocSequence(sequence);
    const double rate = mapdelta::bench::StereoFrameRate(seq, sequence);
    std::printf("bench_vio: %s, %dx%d at %.1f Hz, first %.0f s (budget %.1f ms/frame)\n",
                sequence.c_str(), seq.cam0.intrinsics.width, seq.cam0.intrinsics.height, rate,
                seconds, 1e3 / rate);
    std::vector<Row> rows;
    rows.push_back(Run("current", seq, mapdelta::vio::VioConfig{}, seconds));
    // Session 4's configuration: 200 features, a full window solve on every frame, the gauge
    // in the marginalization prior.
    mapdelta::vio::VioConfig session4;
    session4.tracker.max_features = 200;
    session4.motion_only_non_keyframes = false;
    session4.gauge_free_prior = false;
    rows.push_back(Run("session4", seq, session4, seconds));
    if (baseline) {
      mapdelta::vio::VioConfig old = session4;
      old.analytic_reprojection = false;
      rows.push_back(Run("session1", seq, old, seconds));
    }
    std::printf("%-10s %6s %8s %8s %9s %9s %9s %8s %8s %8s %8s %7s %6s\n", "config", "frames",
                "cpu_ms", "wall_ms", "cpu_fps", "rt(cpu)", "rt(wall)", "front", "optim",
                "margin", "covar", "ate_m", "resets");
    for (const auto& r : rows) Print(r, rate);
    const double current_cpu = rows[0].cpu_ms / rows[0].frames;
    for (size_t k = 1; k < rows.size(); ++k) {
      std::printf("speed-up (thread CPU per frame, %s / current): %.2fx\n", rows[k].name.c_str(),
                  rows[k].cpu_ms / rows[k].frames / current_cpu);
    }
    std::printf("(stage columns: mean wall ms per frame; rt = camera period / VIO time per frame, "
                ">= 1 keeps up on one core)\n");
  } catch (const std::exception& e) {
    std::cerr << "bench_vio: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
