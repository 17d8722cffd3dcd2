#include "mapdelta/sim/generator.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/parallel.hpp"
#include "mapdelta/sim/cloud_sampler.hpp"
#include "mapdelta/sim/dataset_writer.hpp"
#include "mapdelta/sim/imu.hpp"
#include "mapdelta/sim/parallel.hpp"
#include "mapdelta/sim/random.hpp"
#include "mapdelta/sim/raycaster.hpp"
#include "mapdelta/sim/renderer.hpp"
#include "mapdelta/sim/sensor_rig.hpp"

namespace mapdelta::sim {
namespace fs = std::filesystem;

namespace {

constexpr int64_t kT0Ns = 1'600'000'000'000'000'000;  // first sample of every sequence

void MakeDirs(const fs::path& p) {
  std::error_code ec;
  fs::create_directories(p, ec);
  if (ec) throw Error(ErrorCode::kIo, p.string() + ": cannot create directory: " + ec.message());
}

int ThreadCount(const SimConfig& c) { return ResolveThreads(c.threads); }

void WriteScene(const SimConfig& c, const Scene& scene, const Scene& original,
                const std::vector<Change>& changes, const fs::path& dir) {
  MakeDirs(dir);
  WriteObjectsJson((dir / "objects.json").string(), scene, changes);
  WriteCloud((dir / "cloud.pcd").string(), SampleSceneCloud(scene, c.cloud_leaf));
  // Ground truth of the change itself: surfaces of the added / removed buildings.
  for (const Change& ch : changes) {
    const Scene& where = ch.type == "removed" ? original : scene;
    WriteCloud((dir / (ch.type + ".pcd")).string(),
               SampleObjectCloud(where, ch.object, c.cloud_leaf));
  }
}

double PathLength(const SplineTrajectory& traj, double duration) {
  double len = 0;
  Eigen::Vector3d prev = traj.Evaluate(0).p_map;
  for (double t = 0.05; t <= duration + 1e-9; t += 0.05) {
    const Eigen::Vector3d p = traj.Evaluate(t).p_map;
    len += (p - prev).norm();
    prev = p;
  }
  return len;
}

}  // namespace

uint64_t SequenceNoiseKey(uint64_t seed, const std::string& name) {
  // FNV-1a: a name hash that is the same with every standard library.
  uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char ch : name) h = (h ^ ch) * 0x100000001b3ULL;
  return HashCombine(seed, h);
}

Scenes BuildScenes(const SimConfig& c) {
  Validate(c);
  Scenes s;
  s.original = GenerateCity(c, c.seed);
  s.s1 = MakeChangedScene(s.original, 1, c.seed);
  s.s2 = MakeChangedScene(s.original, 2, c.seed);
  return s;
}

SequencePlan PlanSequence(const SimConfig& c, const Scenes& scenes, const std::string& name) {
  const bool s2 = name.rfind("S2", 0) == 0;
  SequencePlan plan{name,
                    s2 ? &scenes.s2 : &scenes.s1,
                    "normal",
                    c.height_01,
                    SplineTrajectory({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}}, 1.0),
                    0,
                    0};
  if (name.size() >= 3 && name.substr(name.size() - 3) == "_02") plan.height = c.height_02;
  if (name == "S1_mirror") plan.variant = "mirror";
  if (name == "S1_dark") plan.variant = "dark";
  // Fly past the removed building first, then the added one. Mirror/dark reuse S1_01's route.
  std::vector<Eigen::Vector2d> targets;
  for (const Change& ch : plan.scene->changes)
    targets.push_back(ch.object.Bounds().Center().head<2>());
  const uint64_t route_seed =
      HashCombine(c.seed, (s2 ? 2 : 1) * 10 + (plan.height == c.height_02 ? 2 : 1));
  const double speed = c.length_m / c.duration_s;
  // Extra route length: the spline needs three knots beyond the end.
  const auto route =
      PlanRoute(plan.scene->scene.streets, targets, c.length_m + 4 * c.spline_spacing, route_seed);
  plan.trajectory = MakeTrajectory(route, plan.height, c.spline_spacing, speed);
  plan.duration_s = std::min(c.duration_s, plan.trajectory.duration());
  plan.length_m = PathLength(plan.trajectory, plan.duration_s);
  return plan;
}

Scene RenderScene(const SequencePlan& plan) {
  Scene scene = plan.scene->scene;
  if (plan.variant == "mirror") {
    const Box removed = plan.scene->changes.front().object.Bounds();
    // A facade mirror beside the route, where the MAV passes closest to the removed building.
    Eigen::Vector2d near = plan.trajectory.Evaluate(0).p_map.head<2>();
    for (double t = 0; t <= plan.duration_s; t += 0.1) {
      const Eigen::Vector2d p = plan.trajectory.Evaluate(t).p_map.head<2>();
      if ((p - removed.Center().head<2>()).norm() < (near - removed.Center().head<2>()).norm())
        near = p;
    }
    MakeMirrors(&scene, removed, near);
  }
  if (plan.variant == "dark") scene.lighting = DarkLighting();
  return scene;
}

namespace {

nlohmann::json MirrorBoxes(const Scene& scene) {
  nlohmann::json mirrors = nlohmann::json::array();
  for (const Object& m : scene.objects) {
    if (m.kind != "mirror") continue;
    const Box b = m.Bounds();
    mirrors.push_back({{"id", m.id},
                       {"min", {b.min.x(), b.min.y(), b.min.z()}},
                       {"max", {b.max.x(), b.max.y(), b.max.z()}}});
  }
  return mirrors;
}

// The folders of mav0 and the cameras' sensor.yaml files.
void WriteCameraFiles(const SimConfig& c, const SensorRig& rig, const fs::path& mav) {
  for (const char* d : {"cam0/data", "cam1/data", "imu0", "state_groundtruth_estimate0"})
    MakeDirs(mav / d);
  if (c.write_depth) MakeDirs(mav / "depth0" / "data");
  const SimCamera& cam0 = rig.cam[0];
  auto radtan = [](const SimCamera& sc) {
    return std::array<double, 4>{sc.distortion.k1, sc.distortion.k2, sc.distortion.p1,
                                 sc.distortion.p2};
  };
  WriteCameraYaml((mav / "cam0/sensor.yaml").string(), cam0.K, c.cam_rate_hz, cam0.T_body_cam,
                  "mapdelta-sim left camera", radtan(cam0));
  WriteCameraYaml((mav / "cam1/sensor.yaml").string(), rig.cam[1].K, c.cam_rate_hz,
                  rig.cam[1].T_body_cam, "mapdelta-sim right camera", radtan(rig.cam[1]));
  if (c.write_depth) {
    WriteCameraYaml((mav / "depth0/sensor.yaml").string(), cam0.K, c.cam_rate_hz, cam0.T_body_cam,
                    "mapdelta-sim ground-truth depth of cam0 (16-bit PNG, millimetres, 0 = none)",
                    radtan(cam0));
  }
}

// Renders and writes both cameras (and the ground-truth depth) at every stamp, in parallel.
void WriteImages(const SimConfig& c, const SequencePlan& plan, const Scene& scene,
                 const SensorRig& rig, const std::vector<int64_t>& stamps, uint64_t seq_key,
                 const fs::path& mav, const std::string& name, const ProgressFn& progress) {
  const EmbreeCaster caster(scene);
  const NoiseParams noise = NoiseFor(c.noise);
  // Distorted lenses: every pixel's ray once per sequence (undistortion is iterative).
  std::vector<Eigen::Vector3f> rays[2];
  for (int ci = 0; ci < 2; ++ci) {
    if (!rig.cam[ci].distortion.IsZero()) rays[ci] = PixelRays(rig.cam[ci]);
  }
  const RenderOptions ropt{c.shadows, 3};
  ParallelFor(stamps.size(), ThreadCount(c), name + " images", progress, [&](size_t k) {
    const double t = static_cast<double>(stamps[k] - kT0Ns) * 1e-9;
    const SE3 T_map_body = plan.trajectory.Evaluate(t).T_map_body * rig.T_vehicle_body;
    const SE3 poses[2] = {T_map_body * rig.cam[0].T_body_cam, T_map_body * rig.cam[1].T_body_cam};
    // Per-thread buffers: the content depends only on k, never on what the thread did before.
    thread_local RenderedView view;
    thread_local std::vector<uint8_t> grey;
    thread_local DepthImage depth;
    for (int ci = 0; ci < 2; ++ci) {
      const PinholeCamera& K = rig.cam[ci].K;
      RenderViewInto(scene, caster, K, poses[ci], ropt, &view,
                     rays[ci].empty() ? nullptr : &rays[ci]);
      const std::string file = std::to_string(stamps[k]) + ".png";
      ToGrey8Into(view, noise.image_sigma, HashCombine(seq_key, 2 * k + static_cast<size_t>(ci)),
                  &grey);
      WriteGreyPng((mav / (ci == 0 ? "cam0/data" : "cam1/data") / file).string(), K.width, K.height,
                   grey);
      if (ci == 0 && c.write_depth) {
        depth.width = K.width;
        depth.height = K.height;
        depth.depth_m = view.depth;
        WriteDepthPng((mav / "depth0/data" / file).string(), depth);
      }
    }
  });
  WriteImageCsv((mav / "cam0/data.csv").string(), stamps);
  WriteImageCsv((mav / "cam1/data.csv").string(), stamps);
  if (c.write_depth) WriteImageCsv((mav / "depth0/data.csv").string(), stamps);
}

// IMU samples over [t0, t0 + span_s] in the body (IMU) axes, with the configured noise.
std::vector<ImuSample> SimulateBodyImu(const SimConfig& c, const SequencePlan& plan,
                                       const SensorRig& rig, double span_s, uint64_t seq_key) {
  const NoiseParams noise = NoiseFor(c.noise);
  if (rig.T_vehicle_body.linear().isIdentity(0.0)) {
    return SimulateImu(plan.trajectory, kT0Ns, c.imu_rate_hz, span_s, noise, seq_key);
  }
  // Clean samples turned into the body (IMU) axes and rounded as imu0/data.csv prints them,
  // then the usual noise: `renoise` on a clean dataset of this rig gives the same samples.
  const Eigen::Matrix3d R_body_vehicle = rig.T_vehicle_body.linear().transpose();
  auto as_written = [](const Eigen::Vector3d& v) {
    Eigen::Vector3d out;
    for (int i = 0; i < 3; ++i) out[i] = std::strtod(FormatCsvNumber(v[i]).c_str(), nullptr);
    return out;
  };
  std::vector<ImuSample> clean = SimulateCleanImu(plan.trajectory, kT0Ns, c.imu_rate_hz, span_s);
  for (ImuSample& s : clean) {
    s.gyro = as_written(R_body_vehicle * s.gyro);
    s.accel = as_written(R_body_vehicle * s.accel);
  }
  return AddImuNoise(clean, c.imu_rate_hz, noise, seq_key);
}

// info.json: what the sequence is, for the tools and the reproduction's report.
nlohmann::json SequenceInfo(const SimConfig& c, const SequencePlan& plan, const SensorRig& rig,
                            const std::string& name, double span_s, size_t frames,
                            double max_yaw_rate, const nlohmann::json& mirrors) {
  nlohmann::json changes = nlohmann::json::array();
  for (const Change& ch : plan.scene->changes)
    changes.push_back({{"type", ch.type}, {"id", ch.object.id}});
  nlohmann::json info = {
      {"sequence", name},
      {"scene", plan.scene->scene.name},
      {"variant", plan.variant},
      {"noise", ToString(c.noise)},
      {"seed", c.seed},
      {"noise_seed", c.seed},
      {"preset", c.preset},
      {"height_m", plan.height},
      {"length_m", plan.length_m},
      {"duration_s", span_s},
      {"t0_ns", kT0Ns},
      {"cam_rate_hz", c.cam_rate_hz},
      {"imu_rate_hz", c.imu_rate_hz},
      {"frames", frames},
      {"baseline_m",
       rig.name == "ideal"
           ? c.baseline
           : (rig.cam[0].T_body_cam.inverse() * rig.cam[1].T_body_cam).translation().norm()},
      {"image_noise_sigma", NoiseFor(c.noise).image_sigma},
      {"max_yaw_rate_rad_s", max_yaw_rate},
      {"changes", changes},
      {"mirrors", mirrors},
      {"ground_truth_cloud", "scenes/" + plan.scene->scene.name + "/cloud.pcd"}};
  if (rig.name != "ideal") info["rig"] = rig.name;  // absent: the ideal rig (older datasets)
  return info;
}

}  // namespace

void GenerateSequence(const SimConfig& c, const Scenes& scenes, const std::string& name,
                      const std::string& out_dir, const ProgressFn& progress, size_t max_frames) {
  const SequencePlan plan = PlanSequence(c, scenes, name);
  const Scene scene = RenderScene(plan);
  const fs::path mav = fs::path(out_dir) / "sequences" / name / "mav0";
  const SensorRig rig = MakeSensorRig(c);
  WriteCameraFiles(c, rig, mav);

  size_t frames = static_cast<size_t>(std::floor(plan.duration_s * c.cam_rate_hz + 1e-9)) + 1;
  if (max_frames > 0) frames = std::min(frames, max_frames);
  std::vector<int64_t> stamps(frames);
  for (size_t k = 0; k < frames; ++k)
    stamps[k] = SampleTimeNs(kT0Ns, static_cast<int64_t>(k), c.cam_rate_hz);
  const uint64_t seq_key = SequenceNoiseKey(c.seed, name);
  WriteImages(c, plan, scene, rig, stamps, seq_key, mav, name, progress);

  // IMU and ground truth over the same time span as the images.
  const double span = static_cast<double>(stamps.back() - kT0Ns) * 1e-9;
  const std::vector<ImuSample> imu = SimulateBodyImu(c, plan, rig, span, seq_key);
  WriteImuYaml((mav / "imu0/sensor.yaml").string(), c.imu_rate_hz, NoiseFor(c.noise));
  WriteImuCsv((mav / "imu0/data.csv").string(), imu);
  WriteGroundTruthCsv((mav / "state_groundtruth_estimate0/data.csv").string(), plan.trajectory, imu,
                      kT0Ns, rig.T_vehicle_body);

  double max_rate = 0;
  for (const ImuSample& s : imu) {
    max_rate =
        std::max(max_rate, std::abs((rig.T_vehicle_body.linear() * (s.gyro - s.bias_gyro)).z()));
  }
  const fs::path info_path = fs::path(out_dir) / "sequences" / name / "info.json";
  std::ofstream out(info_path);
  out << SequenceInfo(c, plan, rig, name, span, frames, max_rate, MirrorBoxes(scene)).dump(1)
      << '\n';
  if (!out) throw Error(ErrorCode::kIo, info_path.string() + ": write failed");
  MD_LOG(kInfo, "sequence " << name << ": " << frames << " stereo frames, " << imu.size()
                            << " IMU samples, " << plan.length_m << " m, max yaw rate " << max_rate
                            << " rad/s");
}

void GenerateDataset(const SimConfig& c, const std::string& out_dir, const ProgressFn& progress) {
  const Scenes scenes = BuildScenes(c);
  const fs::path root(out_dir);
  const std::pair<const Scene*, const std::vector<Change>*> list[3] = {
      {&scenes.original, nullptr},
      {&scenes.s1.scene, &scenes.s1.changes},
      {&scenes.s2.scene, &scenes.s2.changes}};
  const std::vector<Change> none;
  // The three scenes' clouds are independent files: sample them in parallel.
  ParallelFor(3, std::min(3, ThreadCount(c)), "scene clouds", progress, [&](size_t i) {
    WriteScene(c, *list[i].first, scenes.original, list[i].second ? *list[i].second : none,
               root / "scenes" / list[i].first->name);
  });
  for (const std::string& name : c.sequences) GenerateSequence(c, scenes, name, out_dir, progress);
}

}  // namespace mapdelta::sim
