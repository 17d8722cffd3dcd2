// mapdelta-vio: stereo-inertial odometry over an EuRoC-layout sequence; writes TUM files and
// prints per-stage timing (and ATE against the sequence's ground truth when it has one).
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "mapdelta/common/ate.hpp"
#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/trajectory_io.hpp"
#include "mapdelta/vio/run_sequence.hpp"
#include "report.hpp"

namespace {

struct Options {
  std::string sequence, out, keyframes_out, attitude_out, state_out;
  int max_frames = 0, threads = 1;
  bool pipelined = false;
  std::string log_level = "info";
  std::vector<std::string> sets;
};

// Applies "key=value" to the config; false with a message for unknown keys or bad values.
bool ApplySet(const std::string& kv, mapdelta::vio::VioConfig* c, std::string* error) {
  const size_t eq = kv.find('=');
  char* end = nullptr;
  const double v = eq == std::string::npos ? 0 : std::strtod(kv.c_str() + eq + 1, &end);
  if (eq == std::string::npos || !end || *end != '\0') {
    *error = "--set expects KEY=NUMBER, got '" + kv + "'";
    return false;
  }
  const std::string key = kv.substr(0, eq);
  if (key == "iterations")
    c->solver_iterations = static_cast<int>(v);
  else if (key == "sigma_ba")
    c->init_accel_bias_sigma = v;
  else if (key == "sigma_bg")
    c->init_gyro_bias_sigma = v;
  else if (key == "init_bias_gate")
    c->init_max_bias_shift_sigmas = v;
  else if (key == "window")
    c->window_keyframes = static_cast<int>(v);
  else if (key == "init_frames")
    c->init_frames = static_cast<int>(v);
  else if (key == "init_span")
    c->init_min_span_s = v;
  else if (key == "init_iterations")
    c->init_solver_iterations = static_cast<int>(v);
  else if (key == "max_features")
    c->tracker.max_features = static_cast<int>(v);
  else if (key == "min_distance")
    c->tracker.min_distance_px = v;
  else if (key == "klt_window")
    c->tracker.klt_window_px = static_cast<int>(v);
  else if (key == "klt_levels")
    c->tracker.klt_levels = static_cast<int>(v);
  else if (key == "pixel_sigma")
    c->pixel_sigma = v;
  else if (key == "huber")
    c->huber_sigmas = v;
  else if (key == "parallax")
    c->keyframe_parallax = v;
  else if (key == "right_other")
    c->right_in_other_frames = v != 0;
  else if (key == "covariance")
    c->compute_keyframe_covariance = v != 0;
  else if (key == "analytic")
    c->analytic_reprojection = v != 0;
  else if (key == "motion_only")
    c->motion_only_non_keyframes = v != 0;
  else if (key == "smooth_sigma")
    c->tracker.smooth_sigma_px = v;
  else if (key == "min_zncc")
    c->tracker.min_zncc = v;
  else if (key == "grid_cols")
    c->tracker.grid_cols = static_cast<int>(v);
  else if (key == "grid_rows")
    c->tracker.grid_rows = static_cast<int>(v);
  else if (key == "detect_retry")
    c->tracker.detect_retry_frames = static_cast<int>(v);
  else if (key == "stereo_full_searches")
    c->tracker.stereo_full_searches = static_cast<int>(v);
  else if (key == "stereo_klt_levels")
    c->tracker.stereo_klt_levels = static_cast<int>(v);
  else if (key == "stereo_klt_iterations")
    c->tracker.stereo_klt_iterations = static_cast<int>(v);
  else if (key == "back_check_levels")
    c->tracker.back_check_levels = static_cast<int>(v);
  else if (key == "outlier")
    c->outlier_sigmas = v;
  else if (key == "prediction_gate")
    c->prediction_gate_sigmas = v;
  else if (key == "gyro_floor")
    c->min_gyro_noise_density = v;
  else if (key == "accel_floor")
    c->min_accel_noise_density = v;
  else if (key == "gyro_walk_floor")
    c->min_gyro_random_walk = v;
  else if (key == "accel_walk_floor")
    c->min_accel_random_walk = v;
  else if (key == "max_time")
    c->solver_max_time_s = v;
  else if (key == "gauge_free_prior")
    c->gauge_free_prior = v != 0;
  else if (key == "init_pnp_points")
    c->init_max_pnp_points = static_cast<int>(v);
  else if (key == "init_gravity_error")
    c->init_max_gravity_error = v;
  else if (key == "init_velocity_rms")
    c->init_max_velocity_rms_mps = v;
  else {
    *error = "--set: unknown key '" + key + "'";
    return false;
  }
  return true;
}

// False after --help; throws Error(kInvalidArgument) naming the option.
bool Parse(int argc, char** argv, Options* o) {
  mapdelta::cli::Parser cli(
      "mapdelta-vio",
      "Stereo-inertial odometry over an EuRoC-layout sequence; writes TUM files and prints\n"
      "per-stage timing (and ATE against the sequence's ground truth when it has one).\n"
      "Rectified, undistorted stereo is required (as mapdelta-sim writes).");
  cli.Option("sequence", &o->sequence, "EuRoC-layout sequence (folder with mav0/, or mav0 itself)",
             "DIR")
      .Option("out", &o->out, "TUM trajectory of every frame (T_world_body)", "FILE")
      .Option("keyframes-out", &o->keyframes_out,
              "TUM trajectory of keyframes (final window estimates)", "FILE")
      .Option("max-frames", &o->max_frames, "process only the first N stereo frames (0: all)")
      .Option("attitude-out", &o->attitude_out,
              "per-frame roll/pitch/yaw/tilt errors against ground truth (deg)", "FILE")
      .Option("state-out", &o->state_out,
              "per-frame speed and IMU biases (t_s |v| bg_xyz ba_xyz keyframe)", "FILE")
      .Option("threads", &o->threads, "Ceres threads")
      .Flag("pipelined", &o->pipelined,
            "decode + track on a second thread, ahead of the estimator (same estimates, less "
            "wall time)")
      .Repeated("set", &o->sets,
                "override a VioConfig number: iterations, window, init_frames, init_span (s), "
                "init_iterations, analytic (0/1), motion_only (0/1), max_features, klt_window, "
                "klt_levels, min_distance, pixel_sigma, huber, parallax, right_other (0/1), "
                "covariance (0/1), min_zncc, smooth_sigma (px; -1 sized by the image noise), "
                "grid_cols, grid_rows, detect_retry, stereo_full_searches, "
                "stereo_klt_levels, stereo_klt_iterations, back_check_levels, outlier (sigmas), "
                "prediction_gate "
                "(sigmas), sigma_ba "
                "(m/s^2), sigma_bg (rad/s), init_bias_gate (sigmas), gyro_floor, accel_floor, "
                "gyro_walk_floor, accel_walk_floor (IMU noise floors), max_time (s), "
                "gauge_free_prior (0/1), init_pnp_points, init_gravity_error (relative), "
                "init_velocity_rms (m/s)",
                "KEY=VALUE")
      .Option("log-level", &o->log_level, "log level")
      .Choices("log-level", {"debug", "info", "warn", "error", "off"})
      .Require({"sequence", "out"})
      .Footer(mapdelta::cli::kExitCodesFooter);
  if (!cli.Parse(argc, argv, std::cout)) return false;
  if (o->max_frames < 0 || o->threads < 0) {
    mapdelta::cli::FailUsage(cli.program(),
                             "--max-frames and --threads: expected non-negative integers");
  }
  return true;
}

int Run(int argc, char** argv) {
  Options o;
  if (!Parse(argc, argv, &o)) return mapdelta::cli::kExitOk;
  mapdelta::log::Level level = mapdelta::log::Level::kInfo;
  mapdelta::log::ParseLevel(o.log_level, &level);  // one of the parser's choices
  mapdelta::log::SetLevel(level);
  std::string error;
  {
    const mapdelta::EurocSequence seq = mapdelta::ReadEurocSequence(o.sequence);
    mapdelta::vio::VioConfig config;
    config.solver_threads = std::max(1, o.threads);
    for (const auto& kv : o.sets) {
      if (!ApplySet(kv, &config, &error)) mapdelta::cli::FailUsage("mapdelta-vio", error);
    }
    mapdelta::vio::SequenceRunOptions run;
    run.max_frames = o.max_frames;
    run.pipelined = o.pipelined;
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> state(nullptr, &std::fclose);
    if (!o.state_out.empty()) {
      state.reset(std::fopen(o.state_out.c_str(), "w"));
      if (!state) throw mapdelta::Error(mapdelta::ErrorCode::kIo, o.state_out + ": cannot write");
      std::fprintf(state.get(),
                   "# t_s speed_mps bg_x bg_y bg_z (rad/s) ba_x ba_y ba_z (m/s^2) keyframe\n");
    }
    const int64_t t0_ns = seq.StereoFrames().empty() ? 0 : seq.StereoFrames().front().t_ns;
    run.on_frame = [&state, t0_ns](int i, int total, const mapdelta::vio::FrameEstimate& e) {
      if (state && e.initialized) {
        std::fprintf(state.get(), "%.4f %.4f %.6g %.6g %.6g %.6g %.6g %.6g %d\n",
                     1e-9 * static_cast<double>(e.t_ns - t0_ns), e.v_world.norm(), e.gyro_bias.x(),
                     e.gyro_bias.y(), e.gyro_bias.z(), e.accel_bias.x(), e.accel_bias.y(),
                     e.accel_bias.z(), e.keyframe ? 1 : 0);
      }
      if ((i + 1) % 100 == 0 || i + 1 == total) {
        std::fprintf(stderr, "\rframe %d/%d  %s  landmarks %d  %.1f ms   ", i + 1, total,
                     e.initialized ? "tracking" : "initializing", e.landmarks, e.times.total_ms);
        if (i + 1 == total) std::fprintf(stderr, "\n");
      }
    };
    const auto wall_start = std::chrono::steady_clock::now();
    const auto result = mapdelta::vio::RunSequence(seq, config, run);
    const double wall_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    mapdelta::WriteTumTrajectory(o.out, result.frames);
    if (!o.keyframes_out.empty()) mapdelta::WriteTumTrajectory(o.keyframes_out, result.keyframes);
    const double n = std::max(1, result.processed);
    const auto& t = result.times;
    std::printf("frames %d, initialized %d, keyframes %zu, resets %d\n", result.processed,
                result.initialized, result.keyframes.size(), result.resets);
    std::printf(
        "mean ms/frame: frontend %.2f  init %.2f  optimize %.2f  marginalize %.2f  "
        "covariance %.2f  total %.2f\n",
        t.frontend_ms / n, t.initialization_ms / n, t.optimization_ms / n, t.marginalization_ms / n,
        t.covariance_ms / n, t.total_ms / n);
    const double cpu_s = static_cast<double>(std::clock()) / CLOCKS_PER_SEC;
    std::printf(
        "process CPU time %.2f s (all threads; wall times above include waiting for "
        "a shared CPU)\n",
        cpu_s);
    if (result.sequence_duration_s > 0) {
      std::printf("processing %.2f s for %.2f s of sequence (real-time factor %.2f)\n",
                  t.total_ms / 1e3, result.sequence_duration_s,
                  result.sequence_duration_s / std::max(1e-9, t.total_ms / 1e3));
      std::printf("wall time %.2f s including image decoding%s (real-time factor %.2f)\n", wall_s,
                  o.pipelined ? ", front end pipelined" : "",
                  result.sequence_duration_s / std::max(1e-9, wall_s));
    }
    if (!seq.groundtruth.empty() && result.frames.size() >= 3) {
      const auto ate = mapdelta::ComputeAte(seq.groundtruth, result.frames);
      std::printf("ATE (SE3-aligned, %zu poses): rmse %.3f m  mean %.3f  max %.3f\n", ate.pairs,
                  ate.rmse, ate.mean, ate.max);
      mapdelta::AteParams sim3;
      sim3.alignment = mapdelta::AteAlignment::kSim3;
      const auto ate_sim3 = mapdelta::ComputeAte(seq.groundtruth, result.frames, sim3);
      std::printf("ATE (Sim3-aligned): rmse %.3f m, scale %.4f\n", ate_sim3.rmse,
                  ate_sim3.alignment.scale);
      // A reset starts a new odometry world: each tracking segment is aligned on its own.
      for (const auto& s :
           mapdelta::vio::AtePerSegment(seq.groundtruth, result.frames, result.reset_t_ns)) {
        std::printf("segment %.2f..%.2f s: ATE (SE3) rmse %.3f m  max %.3f  (%zu poses)\n",
                    1e-9 * static_cast<double>(s.t_begin_ns - seq.imu_samples.front().t_ns),
                    1e-9 * static_cast<double>(s.t_end_ns - seq.imu_samples.front().t_ns), s.rmse,
                    s.max, s.pairs);
      }
      const auto att = mapdelta::vio::WriteAttitudeErrors(o.attitude_out, seq.groundtruth,
                                                          result.frames, result.reset_t_ns, 2.0);
      std::printf(
          "attitude: max tilt error %.2f deg in the first 2 s of a segment, %.2f after;"
          " max yaw drift %.2f / %.2f deg\n",
          att.max_tilt_early_deg, att.max_tilt_late_deg, att.max_yaw_early_deg,
          att.max_yaw_late_deg);
    }
  }
  return mapdelta::cli::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  return mapdelta::cli::RunMain("mapdelta-vio", [&] { return Run(argc, argv); });
}
