// mapdelta-client run: the whole pipeline over a recorded sequence.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "args.hpp"
#include "commands.hpp"
#include "mapdelta/client/config.hpp"
#include "mapdelta/client/http_transport.hpp"
#include "mapdelta/client/odometry_source.hpp"
#include "mapdelta/client/pipeline.hpp"
#include "mapdelta/client/prior_source.hpp"
#include "mapdelta/client/registration_report.hpp"
#include "mapdelta/client/stereo_input.hpp"
#include "mapdelta/client/uploader.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/trajectory_io.hpp"
#ifdef MAPDELTA_CLIENT_HAS_VIO
#include "mapdelta/client/vio_odometry_source.hpp"
#endif

namespace mapdelta::client::app {
namespace fs = std::filesystem;
namespace {

const char* kRunUsage =
    "usage: mapdelta-client run --sequence DIR --odometry FILE (--prior FILE | --server URL --token T)\n"
    "                           --out DIR [options]\n"
    "  --sequence DIR      EuRoC-layout sequence (mav0/cam0, cam1, imu0; sensor.yaml)\n"
    "  --odometry SRC      'vio': run the stereo-inertial VIO (mapdelta_vio) on the sequence;\n"
    "                      FILE: a recorded odometry trajectory T_odom_body (TUM or EuRoC CSV);\n"
    "                      'gt': the sequence's ground truth (for tests)\n"
    "  --prior FILE        prior map (PCD/PLY, map frame), offline mode\n"
    "  --server URL        fetch prior tiles from the server (cached in OUT/prior_cache) and\n"
    "  --token T           upload the session (unless --no-upload)\n"
    "  --out DIR           vio.txt, fused.txt (TUM, T_map_body), keyframes/, timing.txt,\n"
    "                      registrations.csv (every attempt, pose, sigmas, reason),\n"
    "                      config.yaml (effective config), keyframes.upload_queue/\n"
    "  --config FILE       YAML configuration (see 'mapdelta-client config')\n"
    "  --initial-pose \"x y z qx qy qz qw\"  guess of T_map_body at the first keyframe\n"
    "                      (default: the sequence's ground truth, with a warning)\n"
    "  --max-frames N      stop after N frames\n"
    "  --log-level L       debug | info (default) | warn | error\n"
    "  --inject-reset-at S test fixture: an odometry reset S seconds after the first frame\n"
    "                      (no pose for --inject-reset-gap S, default 0.5, then the odometry\n"
    "                      in another frame: 30 deg yaw, 50 m away), as a VIO reset\n"
    "  --upload-wait S     seconds to wait for the upload to finish at the end (default 120);\n"
    "                      what is left stays queued: 'mapdelta-client upload OUT/keyframes ...'\n"
    "  --no-upload         with --server: only fetch the prior\n";

SE3 ParsePose(const std::string& text) {
  std::istringstream in(text);
  double x, y, z, qx, qy, qz, qw;
  if (!(in >> x >> y >> z >> qx >> qy >> qz >> qw)) {
    throw Error(ErrorCode::kInvalidArgument, "--initial-pose: expected \"x y z qx qy qz qw\"");
  }
  const Eigen::Quaterniond q(qw, qx, qy, qz);
  if (std::abs(q.norm() - 1.0) > 1e-3) throw Error(ErrorCode::kInvalidArgument, "--initial-pose: quaternion is not unit");
  return MakeSE3(q.normalized(), Eigen::Vector3d(x, y, z));
}

void WriteTiming(const std::string& path, const PipelineResult& r) {
  std::ostringstream s;
  s << "stage                       seconds   calls  ms/call\n";
  for (const auto& t : r.timing) {
    char line[160];
    std::snprintf(line, sizeof(line), "%-26s %8.2f %7zu %8.1f\n", t.stage.c_str(), t.seconds, t.calls,
                  t.calls ? 1000.0 * t.seconds / t.calls : 0.0);
    s << line;
  }
  char tail[300];
  std::snprintf(tail, sizeof(tail),
                "wall %.2f s, %zu frames, %zu keyframes, registrations %zu accepted / %zu rejected, "
                "odometry resets %zu (re-anchored %zu, keyframes without map pose %zu)\n",
                r.wall_seconds, r.frames, r.keyframes, r.registrations_accepted, r.registrations_rejected,
                r.odometry_resets, r.segments_reanchored, r.keyframes_unplaced);
  s << tail;
  std::ofstream(path) << s.str();
  std::fprintf(stderr, "%s", s.str().c_str());
}

}  // namespace

int RunPipeline(int argc, char** argv) {
  Args args;
  try {
    args = ParseArgs(argc, argv, {"sequence", "odometry", "prior", "server", "token", "out", "config",
                                  "initial-pose", "max-frames", "upload-wait",
                                  "inject-reset-at", "inject-reset-gap", "log-level"},
                     {"no-upload"});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n%s", e.what(), kRunUsage);
    return 2;
  }
  if (args.help) {
    std::fprintf(stderr, "%s", kRunUsage);
    return 0;
  }
  std::string missing;
  for (const char* key : {"sequence", "odometry", "out"}) {
    if (!args.Has(key)) missing += std::string(" --") + key;
  }
  if (!args.Has("prior") && !args.Has("server")) missing += " --prior|--server";
  if (args.Has("server") && !args.Has("token")) missing += " --token";
  if (!missing.empty()) {
    std::fprintf(stderr, "missing:%s\n%s", missing.c_str(), kRunUsage);
    return 2;
  }
  if (args.Has("log-level")) {
    log::Level level;
    if (!log::ParseLevel(args.Get("log-level"), &level)) {
      std::fprintf(stderr, "--log-level: expected debug, info, warn or error\n");
      return 2;
    }
    log::SetLevel(level);
  }
  const ClientConfig config = args.Has("config") ? LoadClientConfig(args.Get("config")) : ClientConfig{};
  const std::string out = args.Get("out");
  // A second run into the same folder would append a second copy of the keyframes (and a
  // second series of uploads into the first run's session): refuse, and say how to resume.
  if (fs::exists(out + "/keyframes") || fs::exists(out + "/keyframes.upload_queue")) {
    std::fprintf(stderr,
                 "%s already holds the output of an earlier run. Resume its upload with\n"
                 "  mapdelta-client upload %s/keyframes --server URL --token T\n"
                 "or choose another --out.\n", out.c_str(), out.c_str());
    return 2;
  }
  fs::create_directories(out);
  std::ofstream(out + "/config.yaml") << ToYaml(config);
  MD_LOG(kInfo, "effective configuration written to " << out << "/config.yaml");

  std::unique_ptr<OdometrySource> odometry;
  std::unique_ptr<StereoInput> vio_input;  // the VIO reads it while the pipeline runs
  if (args.Get("odometry") == "vio") {
#ifdef MAPDELTA_CLIENT_HAS_VIO
    vio_input = std::make_unique<StereoInput>(ReadEurocSequence(args.Get("sequence")));
    odometry = std::make_unique<VioOdometrySource>(*vio_input);
#else
    throw Error(ErrorCode::kUnsupported, "--odometry vio: this build has no VIO (client/vio)");
#endif
  } else if (args.Get("odometry") == "gt") {
    odometry = std::make_unique<TrajectoryOdometrySource>(ReadEurocSequence(args.Get("sequence")).groundtruth);
  } else {
    odometry = std::make_unique<TrajectoryOdometrySource>(args.Get("odometry"));
  }
  std::unique_ptr<OdometrySource> injected;
  if (args.Has("inject-reset-at")) {
    const auto frames = ReadEurocSequence(args.Get("sequence")).StereoFrames();
    if (frames.empty()) throw Error(ErrorCode::kNotFound, args.Get("sequence") + ": no stereo frames");
    const double at_s = std::stod(args.Get("inject-reset-at"));
    const double gap_s = std::stod(args.Get("inject-reset-gap", "0.5"));
    const SE3 T_new_old = MakeSE3(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 6, Eigen::Vector3d::UnitZ())),
                                  Eigen::Vector3d(30.0, -40.0, 2.0));
    injected = std::make_unique<InjectedResetOdometrySource>(
        odometry.get(), frames.front().t_ns + static_cast<int64_t>(at_s * 1e9), gap_s, T_new_old);
    MD_LOG(kInfo, "injecting an odometry reset at +" << at_s << " s (gap " << gap_s << " s)");
  }
  std::unique_ptr<HttpTransport> transport;
  std::unique_ptr<PriorSource> prior;
  if (args.Has("server")) {
    transport = MakeHttpTransport(args.Get("server"), args.Get("token"), config.upload.timeout_s);
  }
  if (args.Has("prior")) {
    prior = std::make_unique<FilePriorSource>(args.Get("prior"), config.registration.prior_voxel_m);
  } else {
    prior = std::make_unique<ServerPriorSource>(transport.get(), out + "/prior_cache", config.registration.prior_voxel_m);
  }

  PipelineInputs in;
  in.sequence_dir = args.Get("sequence");
  in.odometry = injected ? injected.get() : odometry.get();
  in.prior = prior.get();
  in.keyframe_dir = out + "/keyframes";
  if (args.Has("initial-pose")) in.initial_T_map_body = ParsePose(args.Get("initial-pose"));
  if (args.Has("max-frames")) in.max_frames = std::stoi(args.Get("max-frames"));

  std::unique_ptr<UploadQueue> queue;
  std::unique_ptr<Uploader> uploader;
  std::atomic<bool> stop{false}, upload_finished{false};
  UploadReport upload_report;
  std::thread upload_thread;
  if (transport && !args.Has("no-upload")) {
    queue = std::make_unique<UploadQueue>(out + "/keyframes.upload_queue");
    // The keyframes' camera: the rectified one when the recorded pair is not (StereoInput).
    const StereoInput input(ReadEurocSequence(in.sequence_dir));
    uploader = std::make_unique<Uploader>(config.upload, KeyframeCamera(config, input.rig().left),
                                          queue.get(), transport.get());
    in.uploader = uploader.get();
    upload_thread = std::thread([&] {
      upload_report = uploader->Run(stop);
      upload_finished = true;
    });
  }

  PipelineResult result;
  try {
    result = mapdelta::client::RunPipeline(config, in);
  } catch (...) {
    stop = true;
    if (upload_thread.joinable()) upload_thread.join();
    throw;
  }
  WriteTumTrajectory(out + "/vio.txt", result.vio_T_map_body);
  WriteTumTrajectory(out + "/fused.txt", result.fused_T_map_body);
  WriteTiming(out + "/timing.txt", result);
  WriteRegistrationsCsv(out + "/registrations.csv", result.registrations);
  {
    // Covariance calibration against the sequence's ground truth, when it has one.
    const EurocSequence seq = ReadEurocSequence(in.sequence_dir);
    const CovarianceCalibration c = CalibrateAgainst(result.registrations, seq.groundtruth);
    if (c.registrations > 0) {
      std::fprintf(stderr,
                   "registration covariance vs ground truth (%zu accepted): within 3 sigma %.3f "
                   "(rx %.2f ry %.2f rz %.2f tx %.2f ty %.2f tz %.2f), mean NEES %.1f (6 if calibrated), "
                   "rms error / sigma %.2f %.2f %.2f %.2f %.2f %.2f; covariance factor for 97%% within 3 sigma %.2f\n",
                   c.registrations, c.within_3sigma_all, c.within_3sigma[0], c.within_3sigma[1],
                   c.within_3sigma[2], c.within_3sigma[3], c.within_3sigma[4], c.within_3sigma[5], c.mean_nees,
                   c.rms_over_sigma[0], c.rms_over_sigma[1], c.rms_over_sigma[2], c.rms_over_sigma[3],
                   c.rms_over_sigma[4], c.rms_over_sigma[5], c.scale_for_97);
    }
  }

  if (upload_thread.joinable()) {
    queue->Seal();
    const double wait_s = std::stod(args.Get("upload-wait", "120"));
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<int64_t>(wait_s * 1000));
    while (!upload_finished && std::chrono::steady_clock::now() < deadline) {
      std::fprintf(stderr, "\rupload: %zu keyframes pending", queue->PendingCount());
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
    stop = true;
    upload_thread.join();
    std::fprintf(stderr, "\n");
    if (!upload_report.committed) {
      std::fprintf(stderr, "upload not finished (%s): resume with 'mapdelta-client upload %s/keyframes --server URL --token T'\n",
                   upload_report.fatal.empty() ? "timed out" : upload_report.fatal.c_str(), out.c_str());
      return 3;
    }
    std::fprintf(stderr, "upload: session %s committed (%zu keyframes)\n", upload_report.session_id.c_str(),
                 upload_report.uploaded);
  }
  return 0;
}

}  // namespace mapdelta::client::app
