// bench_vio: the stereo-inertial odometry (client/vio) on a prefix of an EuRoC-layout sequence
// (the simulator's, e.g. paper preset 800x450 at 30 Hz, or a real EuRoC folder), the current
// configuration beside the same without the noise smoothing (tracker.smooth_sigma_px 0: on a
// noisy sequence, what the smoothing costs and buys), session 4's (200 features, full window
// solves on every frame, gauge in the prior) and session 1's (that plus autodiff reprojection
// Jacobians).
//
// Per configuration, on one thread (image decoding excluded): the front end (TrackFrame:
// rectification, KLT, detection, stereo) and the estimator (AddTrackedFrame) timed apart, wall
// and the calling thread's CPU per frame; when the first pose came; ATE. Front-end quality from
// the tracked feature ids: features per frame, the share of the previous frame's features
// tracked into this one, the mean length of the tracks that ended, the share with a stereo
// match, and the share the estimator kept as landmarks (its inliers).
// Then the current configuration pipelined as the client runs it (decoding and front end on a
// second thread, RunSequence): wall time against the sequence's duration = processing
// real-time factor on this machine.
//
// On a shared machine wall times include waiting for a CPU, and OpenCV may run parts of the
// front end on its worker threads (not in the thread CPU): compare runs made side by side.
// Uses only the public API (odometry.hpp, run_sequence.hpp), so this file also builds against
// older trees for side-by-side runs.
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <unordered_map>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "mapdelta/common/ate.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/vio/odometry.hpp"
#include "mapdelta/vio/run_sequence.hpp"
#include "sequence_bench_args.hpp"

namespace {

const char* kDescription =
    "VIO benchmark on the first --seconds of a sequence (default 20 here), beside the session-1\n"
    "configuration (bench/README.md).";

using Clock = std::chrono::steady_clock;

double ThreadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

double MsSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

// Track statistics from the ids of consecutive frames.
struct TrackQuality {
  long features = 0, stereo = 0, landmarks = 0, prev_features = 0, carried = 0, ended = 0,
       ended_length = 0;
  std::unordered_map<uint64_t, int> length;  // frames each live track has been seen in

  void Add(const mapdelta::vio::FrameFeatures& f, int estimator_landmarks) {
    std::unordered_map<uint64_t, int> next;
    for (const auto& o : f.features) {
      const auto it = length.find(o.id);
      next[o.id] = it == length.end() ? 1 : it->second + 1;
      if (it != length.end()) ++carried;
      if (o.has_right) ++stereo;
    }
    for (const auto& [id, n] : length) {
      if (!next.count(id)) {
        ++ended;
        ended_length += n;
      }
    }
    prev_features += static_cast<long>(length.size());
    features += static_cast<long>(f.features.size());
    landmarks += estimator_landmarks;
    length.swap(next);
  }
};

struct Row {
  std::string name;
  int frames = 0, resets = 0, initialized = 0;
  double seq_s = 0, first_pose_s = -1, ate = -1;
  double front_wall_ms = 0, front_cpu_ms = 0, est_wall_ms = 0, est_cpu_ms = 0;
  TrackQuality quality;
  long landmark_features = 0;  // features of frames with a pose (the landmarks' denominator)
};

void FeedImu(const mapdelta::EurocSequence& seq, int64_t t_ns, size_t* next,
             mapdelta::vio::StereoInertialOdometry* odo) {
  const auto& imu = seq.imu_samples;
  while (*next < imu.size() && imu[*next].t_ns <= t_ns) odo->AddImu(imu[(*next)++]);
  if (*next < imu.size()) odo->AddImu(imu[*next]);
}

Row Run(const std::string& name, const mapdelta::EurocSequence& seq,
        const mapdelta::vio::VioConfig& config, double seconds) {
  using namespace mapdelta;
  vio::StereoInertialOdometry odo(config, seq.cam0, seq.cam1, seq.imu);
  const auto frames = seq.StereoFrames();
  Row row;
  row.name = name;
  Trajectory estimate;
  size_t imu_index = 0;
  for (const auto& f : frames) {
    const double t_s = 1e-9 * static_cast<double>(f.t_ns - frames.front().t_ns);
    if (seconds > 0 && t_s > seconds) break;  // --seconds 0: the whole sequence
    FeedImu(seq, f.t_ns, &imu_index, &odo);
    const cv::Mat left = cv::imread(f.left_path, cv::IMREAD_GRAYSCALE);
    const cv::Mat right = cv::imread(f.right_path, cv::IMREAD_GRAYSCALE);
    if (left.empty() || right.empty()) throw Error(ErrorCode::kIo, f.left_path + ": cannot read");
    auto wall = Clock::now();
    double cpu = ThreadCpuMs();
    const vio::TrackedFrame tracked =
        odo.TrackFrame(f.t_ns, {left.cols, left.rows, static_cast<int>(left.step), left.data},
                       {right.cols, right.rows, static_cast<int>(right.step), right.data});
    row.front_cpu_ms += ThreadCpuMs() - cpu;
    row.front_wall_ms += MsSince(wall);
    wall = Clock::now();
    cpu = ThreadCpuMs();
    const vio::FrameEstimate e = odo.AddTrackedFrame(tracked);
    row.est_cpu_ms += ThreadCpuMs() - cpu;
    row.est_wall_ms += MsSince(wall);
    ++row.frames;
    if (e.reset) ++row.resets;
    row.quality.Add(tracked.features, e.initialized ? e.landmarks : 0);
    if (e.initialized) {
      if (row.first_pose_s < 0) row.first_pose_s = t_s;
      ++row.initialized;
      row.landmark_features += e.features;
      estimate.push_back({e.t_ns, e.T_world_body});
    }
    row.seq_s = t_s;
    if (row.frames % 100 == 0) std::fprintf(stderr, "\r%s: frame %d", name.c_str(), row.frames);
  }
  std::fprintf(stderr, "\n");
  if (!seq.groundtruth.empty() && estimate.size() >= 3)
    row.ate = ComputeAte(seq.groundtruth, estimate).rmse;
  return row;
}

void PrintTimes(const Row& r, double cam_rate_hz) {
  const double n = std::max(1, r.frames);
  const double budget_ms = 1e3 / cam_rate_hz;
  std::printf("%-10s %6d %9.2f %9.2f %9.2f %9.2f %8.2f %8.2f %7.2f %7.3f %6d\n", r.name.c_str(),
              r.frames, r.front_wall_ms / n, r.front_cpu_ms / n, r.est_wall_ms / n,
              r.est_cpu_ms / n, budget_ms / ((r.front_cpu_ms + r.est_cpu_ms) / n),
              budget_ms / ((r.front_wall_ms + r.est_wall_ms) / n), r.first_pose_s, r.ate, r.resets);
}

void PrintQuality(const Row& r) {
  const TrackQuality& q = r.quality;
  const double n = std::max(1, r.frames);
  auto ratio = [](double a, double b) { return b > 0 ? a / b : 0.0; };
  std::printf("%-10s %9.1f %9.3f %9.2f %9.3f %10.3f\n", r.name.c_str(), q.features / n,
              ratio(q.carried, q.prev_features), ratio(q.ended_length, q.ended),
              ratio(q.stereo, q.features), ratio(q.landmarks, r.landmark_features));
}

}  // namespace

int main(int argc, char** argv) {
  mapdelta::bench::SequenceBenchArgs args;
  args.seconds = 20;
  if (auto exit_code = mapdelta::bench::ParseSequenceBenchArgs(argc, argv, "bench_vio",
                                                               kDescription, false, &args)) {
    return *exit_code;
  }
  const std::string& sequence = args.sequence;
  const double seconds = args.seconds;
  mapdelta::log::SetLevel(mapdelta::log::Level::kWarn);
  try {
    const auto seq = mapdelta::ReadEurocSequence(sequence);
    const double rate = mapdelta::bench::StereoFrameRate(seq, sequence);
    std::printf("bench_vio: %s, %dx%d at %.1f Hz, first %.1f s (budget %.1f ms/frame)\n",
                sequence.c_str(), seq.cam0.intrinsics.width, seq.cam0.intrinsics.height, rate,
                seconds, 1e3 / rate);
    std::vector<Row> rows;
    rows.push_back(Run("current", seq, mapdelta::vio::VioConfig{}, seconds));
    // The same without the smoothing of noisy frames: identical to "current" on a sequence
    // whose measured noise is below kSmoothingMinNoise (e.g. real EuRoC, the small-noise preset).
    mapdelta::vio::VioConfig unsmoothed;
    unsmoothed.tracker.smooth_sigma_px = 0.0;
    rows.push_back(Run("unsmoothed", seq, unsmoothed, seconds));
    // Session 4's configuration: 200 features, a full window solve on every frame, the gauge
    // in the marginalization prior.
    mapdelta::vio::VioConfig session4;
    session4.tracker.max_features = 200;
    session4.motion_only_non_keyframes = false;
    session4.gauge_free_prior = false;
    rows.push_back(Run("session4", seq, session4, seconds));
    if (args.baseline) {
      mapdelta::vio::VioConfig old = session4;
      old.analytic_reprojection = false;
      rows.push_back(Run("session1", seq, old, seconds));
    }
    std::printf("%-10s %6s %9s %9s %9s %9s %8s %8s %7s %7s %6s\n", "config", "frames", "front_ms",
                "front_cpu", "est_ms", "est_cpu", "rt(cpu)", "rt(wall)", "pose_s", "ate_m",
                "resets");
    for (const auto& r : rows) PrintTimes(r, rate);
    std::printf(
        "(per frame; rt = camera period / (front end + estimator) on one thread;\n"
        " pose_s = time of the first pose after the first frame)\n");
    std::printf("smoothing: front end %.2fx the unsmoothed one's thread CPU, %.2fx its wall\n",
                rows[0].front_cpu_ms / std::max(1e-9, rows[1].front_cpu_ms),
                rows[0].front_wall_ms / std::max(1e-9, rows[1].front_wall_ms));
    std::printf("%-10s %9s %9s %9s %9s %10s\n", "config", "features", "tracked", "track_len",
                "stereo", "landmarks");
    for (const auto& r : rows) PrintQuality(r);
    std::printf(
        "(features per frame; tracked = share of the previous frame's features found\n"
        " again; track_len = mean frames of the tracks that ended; stereo = share with a\n"
        " right match; landmarks = share the estimator kept, frames with a pose)\n");
    mapdelta::vio::SequenceRunOptions pipelined;
    pipelined.pipelined = true;
    pipelined.max_frames = rows[0].frames;
    const auto wall0 = Clock::now();
    const auto result = mapdelta::vio::RunSequence(seq, mapdelta::vio::VioConfig{}, pipelined);
    const double wall_s = 1e-3 * MsSince(wall0);
    const double duration_s = result.sequence_duration_s + 1.0 / rate;
    std::printf(
        "pipelined (decode + front end on a second thread): %d frames, %.2f s of\n"
        " sequence in %.2f s wall: processing real-time factor %.2f\n",
        result.processed, duration_s, wall_s, duration_s / wall_s);
  } catch (const std::exception& e) {
    std::cerr << "bench_vio: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
