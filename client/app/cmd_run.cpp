// mapdelta-client run: the whole pipeline over a recorded sequence.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <thread>

#include "commands.hpp"
#include "mapdelta/client/config.hpp"
#include "mapdelta/client/http_transport.hpp"
#include "mapdelta/client/odometry_source.hpp"
#include "mapdelta/client/pipeline.hpp"
#include "mapdelta/client/prior_source.hpp"
#include "mapdelta/client/registration_report.hpp"
#include "mapdelta/client/stereo_input.hpp"
#include "mapdelta/client/upload_queue.hpp"
#include "mapdelta/client/uploader.hpp"
#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/trajectory_io.hpp"
#include "progress_line.hpp"
#ifdef MAPDELTA_CLIENT_HAS_VIO
#include "mapdelta/client/vio_odometry_source.hpp"
#endif

namespace mapdelta::client::app {
namespace fs = std::filesystem;
namespace {

// The command line of 'run', parsed and checked before anything is read.
struct RunOptions {
  std::string sequence, odometry, prior, server, token, out, config, initial_pose,
      log_level = "info";
  int max_frames = 0;
  double upload_wait_s = 120, inject_reset_at_s = 0, inject_reset_gap_s = 0.5;
  bool inject_reset = false, no_upload = false;
};

// False after --help; throws Error(kInvalidArgument) for usage errors.
bool ParseRunOptions(int argc, char** argv, RunOptions* o) {
  cli::Parser cli(
      "mapdelta-client run",
      "The whole vehicle pipeline over a recorded sequence: stereo depth, temporal filter,\n"
      "odometry, prior-map registration, fusion, keyframes (and their upload with --server).");
  cli.Option("sequence", &o->sequence, "EuRoC-layout sequence (mav0/cam0, cam1, imu0; sensor.yaml)",
             "DIR")
      .Option("odometry", &o->odometry,
              "'vio': the stereo-inertial VIO (mapdelta_vio) on the sequence; FILE: a recorded "
              "odometry "
              "trajectory T_odom_body (TUM or EuRoC CSV); 'gt': the sequence's ground truth (for "
              "tests)",
              "SRC")
      .Option("prior", &o->prior, "prior map (PCD/PLY, map frame), offline mode", "FILE")
      .Option(
          "server", &o->server,
          "fetch prior tiles from the server (cached in OUT/prior_cache) and upload the session "
          "(unless --no-upload)",
          "URL")
      .Option("token", &o->token, "vehicle token for --server", "T")
      .Option(
          "out", &o->out,
          "vio.txt, fused.txt (TUM, T_map_body), keyframes/, timing.txt, registrations.csv (every "
          "attempt, pose, sigmas, reason), config.yaml (effective config), keyframes.upload_queue/",
          "DIR")
      .Option("config", &o->config, "YAML configuration (see 'mapdelta-client config')", "FILE")
      .Option(
          "initial-pose", &o->initial_pose,
          "guess of T_map_body at the first keyframe (default: the sequence's ground truth, with a "
          "warning)",
          "\"x y z qx qy qz qw\"")
      .Option("max-frames", &o->max_frames, "stop after N frames (0: all)")
      .Option("log-level", &o->log_level, "log level")
      .Choices("log-level", {"debug", "info", "warn", "error", "off"})
      .Option("inject-reset-at", &o->inject_reset_at_s,
              "test fixture: an odometry reset S seconds after the first frame (no pose for "
              "--inject-reset-gap, then the odometry in another frame: 30 deg yaw, 50 m away), as "
              "a VIO reset",
              "S")
      .Option("inject-reset-gap", &o->inject_reset_gap_s,
              "seconds without odometry at the injected reset", "S")
      .Option("upload-wait", &o->upload_wait_s,
              "seconds to wait for the upload to finish at the end; what is left stays queued: "
              "'mapdelta-client upload OUT/keyframes ...'",
              "S")
      .Flag("no-upload", &o->no_upload, "with --server: only fetch the prior")
      .Require({"sequence", "odometry", "out"})
      .Footer(std::string(
          "Exit codes: 0 success, 1 runtime failure or unreadable/malformed input, 2 usage or "
          "configuration error, 3 the upload did not finish (resume it with 'upload')."));
  if (!cli.Parse(argc, argv, std::cout)) return false;
  if (o->prior.empty() == o->server.empty())
    cli::FailUsage(cli.program(), "expected one of --prior and --server");
  if (!o->server.empty() && o->token.empty())
    cli::FailUsage(cli.program(), "--server needs --token");
  o->inject_reset = cli.Given("inject-reset-at");
  return true;
}

SE3 ParsePose(const std::string& text) {
  std::istringstream in(text);
  double x, y, z, qx, qy, qz, qw;
  if (!(in >> x >> y >> z >> qx >> qy >> qz >> qw)) {
    throw Error(ErrorCode::kInvalidArgument, "--initial-pose: expected \"x y z qx qy qz qw\"");
  }
  const Eigen::Quaterniond q(qw, qx, qy, qz);
  if (std::abs(q.norm() - 1.0) > 1e-3)
    throw Error(ErrorCode::kInvalidArgument, "--initial-pose: quaternion is not unit");
  return MakeSE3(q.normalized(), Eigen::Vector3d(x, y, z));
}

void WriteTiming(const std::string& path, const PipelineResult& r) {
  std::ostringstream s;
  s << "stage                       seconds   calls  ms/call\n";
  for (const auto& t : r.timing) {
    char line[160];
    std::snprintf(line, sizeof(line), "%-26s %8.2f %7zu %8.1f\n", t.stage.c_str(), t.seconds,
                  t.calls, t.calls ? 1000.0 * t.seconds / t.calls : 0.0);
    s << line;
  }
  char tail[300];
  std::snprintf(
      tail, sizeof(tail),
      "wall %.2f s, %zu frames, %zu keyframes, registrations %zu accepted / %zu rejected, "
      "odometry resets %zu (re-anchored %zu, keyframes without map pose %zu)\n",
      r.wall_seconds, r.frames, r.keyframes, r.registrations_accepted, r.registrations_rejected,
      r.odometry_resets, r.segments_reanchored, r.keyframes_unplaced);
  s << tail;
  std::ofstream(path) << s.str();
  std::fprintf(stderr, "%s", s.str().c_str());
}

// Refuses an OUT that holds an earlier run (a second run would append a second copy of the
// keyframes, and a second series of uploads into the first run's session); says how to resume.
bool PrepareOutputFolder(const std::string& out, const ClientConfig& config) {
  if (fs::exists(out + "/keyframes") || fs::exists(out + "/keyframes.upload_queue")) {
    std::fprintf(stderr,
                 "%s already holds the output of an earlier run. Resume its upload with\n"
                 "  mapdelta-client upload %s/keyframes --server URL --token T\n"
                 "or choose another --out.\n",
                 out.c_str(), out.c_str());
    return false;
  }
  fs::create_directories(out);
  std::ofstream(out + "/config.yaml") << ToYaml(config);
  MD_LOG(kInfo, "effective configuration written to " << out << "/config.yaml");
  return true;
}

// The odometry the options name, and (with --inject-reset-at) the reset-injecting wrapper
// around it; Get() is the one the pipeline reads.
struct Odometry {
  std::unique_ptr<OdometrySource> source, injected;
  OdometrySource* Get() const { return injected ? injected.get() : source.get(); }
};

Odometry MakeOdometry(const RunOptions& o, const StereoInput& input, const VioSettings& vio) {
  Odometry odometry;
  if (o.odometry == "vio") {
#ifdef MAPDELTA_CLIENT_HAS_VIO
    odometry.source = std::make_unique<VioOdometrySource>(input, vio);
#else
    throw Error(ErrorCode::kUnsupported, "--odometry vio: this build has no VIO (client/vio)");
#endif
  } else if (o.odometry == "gt") {
    odometry.source = std::make_unique<TrajectoryOdometrySource>(input.sequence().groundtruth);
  } else {
    odometry.source = std::make_unique<TrajectoryOdometrySource>(o.odometry);
  }
  if (o.inject_reset) {
    const auto frames = input.sequence().StereoFrames();
    if (frames.empty()) throw Error(ErrorCode::kNotFound, o.sequence + ": no stereo frames");
    const SE3 T_new_old =
        MakeSE3(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 6, Eigen::Vector3d::UnitZ())),
                Eigen::Vector3d(30.0, -40.0, 2.0));
    odometry.injected = std::make_unique<InjectedResetOdometrySource>(
        odometry.source.get(),
        frames.front().t_ns + static_cast<int64_t>(o.inject_reset_at_s * 1e9), o.inject_reset_gap_s,
        T_new_old, &input.sequence().imu_samples, input.sequence().imu.T_body_imu.linear());
    MD_LOG(kInfo, "injecting an odometry reset at +" << o.inject_reset_at_s << " s (gap "
                                                     << o.inject_reset_gap_s << " s)");
  }
  return odometry;
}

// The durable upload queue and the uploader draining it on a thread of its own, while the
// pipeline runs (only with --server and without --no-upload).
class BackgroundUpload {
 public:
  // map_origin: the prior's origin, added back to the pipeline's local poses on upload.
  BackgroundUpload(const ClientConfig& config, const PinholeCamera& keyframe_camera,
                   const std::string& queue_dir, HttpTransport* transport,
                   const Eigen::Vector3d& map_origin)
      : queue_(queue_dir), uploader_(config.upload, keyframe_camera, &queue_, transport) {
    uploader_.SetMapOrigin(map_origin);
    thread_ = std::thread([this] {
      report_ = uploader_.Run(stop_);
      finished_ = true;
    });
  }
  ~BackgroundUpload() { Stop(); }
  Uploader* uploader() { return &uploader_; }
  void Stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  // Seals the queue and waits up to wait_s for the uploader to send and commit it, with a
  // progress line; then stops it. Returns its report.
  UploadReport Finish(double wait_s) {
    queue_.Seal();
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::milliseconds(static_cast<int64_t>(wait_s * 1000));
    ProgressLine progress;
    while (!finished_ && std::chrono::steady_clock::now() < deadline) {
      progress.Update("upload: " + std::to_string(queue_.PendingCount()) + " keyframes pending");
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
    Stop();
    progress.Finish();
    return report_;
  }

 private:
  UploadQueue queue_;
  Uploader uploader_;
  std::atomic<bool> stop_{false}, finished_{false};
  UploadReport report_;
  std::thread thread_;
};

// Covariance calibration of the accepted registrations against the sequence's ground truth,
// when it has one.
void ReportCovarianceCalibration(const PipelineResult& result, const Trajectory& groundtruth) {
  const CovarianceCalibration c = CalibrateAgainst(result.registrations, groundtruth);
  if (c.registrations == 0) return;
  std::fprintf(stderr,
               "registration covariance vs ground truth (%zu accepted): within 3 sigma %.3f "
               "(rx %.2f ry %.2f rz %.2f tx %.2f ty %.2f tz %.2f), mean NEES %.1f (6 if "
               "calibrated), rms error / sigma %.2f %.2f %.2f %.2f %.2f %.2f; covariance factor "
               "for 97%% within 3 sigma %.2f\n",
               c.registrations, c.within_3sigma_all, c.within_3sigma[0], c.within_3sigma[1],
               c.within_3sigma[2], c.within_3sigma[3], c.within_3sigma[4], c.within_3sigma[5],
               c.mean_nees, c.rms_over_sigma[0], c.rms_over_sigma[1], c.rms_over_sigma[2],
               c.rms_over_sigma[3], c.rms_over_sigma[4], c.rms_over_sigma[5], c.scale_for_97);
}

}  // namespace

int RunPipelineCommand(int argc, char** argv) {
  RunOptions o;
  if (!ParseRunOptions(argc, argv, &o)) return cli::kExitOk;
  log::Level level = log::Level::kInfo;
  log::ParseLevel(o.log_level, &level);  // one of the parser's choices
  log::SetLevel(level);
  const ClientConfig config = o.config.empty() ? ClientConfig{} : LoadClientConfig(o.config);
  const std::string& out = o.out;
  if (!PrepareOutputFolder(out, config)) return cli::kExitUsage;

  // The sequence, read and rectified once for every stage (odometry, depth, upload camera).
  const StereoInput input(ReadEurocSequence(o.sequence));
  const Odometry odometry = MakeOdometry(o, input, config.vio);
  std::unique_ptr<HttpTransport> transport;
  if (!o.server.empty()) transport = MakeHttpTransport(o.server, o.token, config.upload.timeout_s);
  std::unique_ptr<PriorSource> prior;
  if (!o.prior.empty()) {
    prior = std::make_unique<FilePriorSource>(o.prior, config.registration.prior_voxel_m);
  } else {
    prior = std::make_unique<ServerPriorSource>(transport.get(), out + "/prior_cache",
                                                config.registration.prior_voxel_m);
  }

  PipelineInputs in;
  in.sequence_dir = o.sequence;
  in.input = &input;
  in.odometry = odometry.Get();
  in.prior = prior.get();
  in.keyframe_dir = out + "/keyframes";
  // The pipeline runs in the prior's local frame (prior_source.hpp): the initial pose given in
  // map coordinates and the uploaded poses are converted here, at the edges.
  const Eigen::Vector3d map_origin = prior->MapOrigin();
  if (!o.initial_pose.empty()) {
    SE3 T_map_body = ParsePose(o.initial_pose);
    T_map_body.translation() -= map_origin;
    in.initial_T_map_body = T_map_body;
  }
  in.max_frames = o.max_frames;
  std::optional<BackgroundUpload> upload;
  if (transport && !o.no_upload) {
    upload.emplace(config, KeyframeCamera(config, input.rig().left),
                   out + "/keyframes.upload_queue", transport.get(), map_origin);
    in.uploader = upload->uploader();
  }

  const PipelineResult result = RunPipeline(config, in);  // on a throw, ~BackgroundUpload stops
  WriteTumTrajectory(out + "/vio.txt", result.vio_T_map_body);
  WriteTumTrajectory(out + "/fused.txt", result.fused_T_map_body);
  WriteTiming(out + "/timing.txt", result);
  WriteRegistrationsCsv(out + "/registrations.csv", result.registrations);
  ReportCovarianceCalibration(result, input.sequence().groundtruth);
  if (!upload) return cli::kExitOk;
  const UploadReport report = upload->Finish(o.upload_wait_s);
  if (!report.committed) {
    std::fprintf(stderr,
                 "upload not finished (%s): resume with 'mapdelta-client upload %s/keyframes "
                 "--server URL --token T'\n",
                 report.fatal.empty() ? "timed out" : report.fatal.c_str(), out.c_str());
    return 3;
  }
  std::fprintf(stderr, "upload: session %s committed (%zu keyframes)\n", report.session_id.c_str(),
               report.uploaded);
  return cli::kExitOk;
}

}  // namespace mapdelta::client::app
