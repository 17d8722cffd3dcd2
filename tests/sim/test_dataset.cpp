// Whole-dataset properties: EuRoC layout readable by common's loaders, byte-identical output
// for the same seed (whatever the thread count), changes described and clearly visible.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/trajectory_io.hpp"
#include "mapdelta/sim/dataset_writer.hpp"
#include "mapdelta/sim/generator.hpp"
#include "mapdelta/sim/raycaster.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta::sim {
namespace {
namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const auto dir = mapdelta::testing::FreshTempDir("mapdelta_test_sim_" + name);
  fs::remove_all(dir);
  return dir.string();
}

// A very small dataset: the tiny city, thumbnail images, 1.5 s.
SimConfig Mini() {
  SimConfig c = PresetConfig("tiny");
  c.width = 80;
  c.height = 45;
  c.fx = c.fy = 40;
  c.cx = 40;
  c.cy = 22.5;
  c.duration_s = 1.5;
  c.length_m = 6;
  c.cloud_leaf = 0.6;
  c.noise = NoiseLevel::kSmall;
  c.sequences = {"S1_01", "S1_mirror"};
  return c;
}

std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::map<std::string, std::string> AllFiles(const std::string& root) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (e.is_regular_file()) files[fs::relative(e.path(), root).string()] = Slurp(e.path());
  }
  return files;
}

TEST(SimDataset, SameSeedGivesByteIdenticalFilesWhateverTheThreads) {
  SimConfig a = Mini();
  a.threads = 1;
  SimConfig b = Mini();
  b.threads = 2;
  const std::string da = TempDir("det_a"), db = TempDir("det_b"), dc = TempDir("det_c");
  GenerateDataset(a, da, nullptr);
  GenerateDataset(b, db, nullptr);
  const auto fa = AllFiles(da), fb = AllFiles(db);
  ASSERT_GT(fa.size(), 60u);
  ASSERT_EQ(fa.size(), fb.size());
  for (const auto& [name, bytes] : fa) {
    ASSERT_TRUE(fb.count(name)) << name;
    EXPECT_TRUE(bytes == fb.at(name)) << name << " differs between runs";
  }
  // A different seed gives a different city.
  SimConfig c = Mini();
  c.seed = 2;
  c.sequences = {"S1_01"};
  GenerateDataset(c, dc, nullptr);
  EXPECT_NE(Slurp(fs::path(da) / "scenes/original/objects.json"),
            Slurp(fs::path(dc) / "scenes/original/objects.json"));
}

TEST(SimDataset, EurocLayoutLoadsWithCommonReaders) {
  const SimConfig c = Mini();
  const std::string dir = TempDir("layout");
  GenerateDataset(c, dir, nullptr);
  const fs::path mav = fs::path(dir) / "sequences/S1_01/mav0";
  const Trajectory gt =
      ReadEurocTrajectory((mav / "state_groundtruth_estimate0/data.csv").string());
  EXPECT_EQ(gt.size(), 301u);  // 1.5 s at 200 Hz
  EXPECT_EQ(gt[1].t_ns - gt[0].t_ns, 5'000'000);
  // Image list: header + 31 frames at 20 Hz, each file present.
  std::ifstream csv(mav / "cam0/data.csv");
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "#timestamp [ns],filename");
  int frames = 0;
  while (std::getline(csv, line)) {
    const std::string file = line.substr(line.find(',') + 1);
    EXPECT_TRUE(fs::exists(mav / "cam0/data" / file)) << file;
    EXPECT_TRUE(fs::exists(mav / "cam1/data" / file)) << file;
    ++frames;
  }
  EXPECT_EQ(frames, 31);
  const std::string yaml = Slurp(mav / "cam1/sensor.yaml");
  EXPECT_NE(yaml.find("intrinsics: [40, 40, 40, 22.5]"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("resolution: [80, 45]"), std::string::npos);
  const std::string imu_yaml = Slurp(mav / "imu0/sensor.yaml");
  EXPECT_NE(imu_yaml.find("gyroscope_noise_density: 0.0004 "), std::string::npos) << imu_yaml;
  EXPECT_NE(imu_yaml.find("accelerometer_random_walk: 0.0003 "), std::string::npos);
  const DepthImage depth = ReadDepthPng((mav / "depth0/data/1600000000000000000.png").string());
  EXPECT_EQ(depth.width, 80);
  EXPECT_GT(depth.CountValid(), 1000u);
  const PointCloud cloud = ReadCloud((fs::path(dir) / "scenes/original/cloud.pcd").string());
  EXPECT_GT(cloud.size(), 20000u);
  const nlohmann::json info =
      nlohmann::json::parse(Slurp(fs::path(dir) / "sequences/S1_mirror/info.json"));
  EXPECT_EQ(info["scene"], "S1");
  EXPECT_EQ(info["variant"], "mirror");
  EXPECT_EQ(info["mirrors"].size(), 2u);
}

TEST(SimDataset, ChangesAreDescribedAndClearlySeenFromTheTrajectory) {
  const SimConfig c = PresetConfig("tiny");
  const Scenes scenes = BuildScenes(c);
  const PinholeCamera cam = [&] {
    PinholeCamera k;
    k.width = 100;
    k.height = 56;
    k.fx = k.fy = 50;
    k.cx = 50;
    k.cy = 28;
    return k;
  }();
  for (const ChangedScene* cs : {&scenes.s1, &scenes.s2}) {
    ASSERT_EQ(cs->changes.size(), 2u);
    const Object& removed = cs->changes[0].object;
    const Object& added = cs->changes[1].object;
    EXPECT_EQ(cs->changes[0].type, "removed");
    EXPECT_TRUE(scenes.original.Find(removed.id) && !cs->scene.Find(removed.id));
    EXPECT_TRUE(!scenes.original.Find(added.id) && cs->scene.Find(added.id));
    // The added building must not intersect any other object.
    for (const Object& o : cs->scene.objects) {
      if (o.id == added.id) continue;
      const Box a = added.Bounds(), b = o.Bounds();
      const bool overlap =
          (a.min.array() < b.max.array()).all() && (b.min.array() < a.max.array()).all();
      EXPECT_FALSE(overlap) << "added building overlaps object " << o.id;
    }
    // Seen: in some frame of the _01 flight, >= 3% of the image within 45 m is the building
    // (the removed one is looked for in the original scene, along the same flight).
    const SequencePlan plan = PlanSequence(c, scenes, cs->scene.name + "_01");
    const EmbreeCaster now(cs->scene), before(scenes.original);
    auto best_fraction = [&](const RayCaster& caster, const Scene& scene, int id) {
      double best = 0;
      for (double t = 0; t <= plan.duration_s; t += 0.5) {
        const SE3 T = plan.trajectory.Evaluate(t).T_map_body * BodyToCam0();
        int n = 0;
        for (int v = 0; v < cam.height; ++v) {
          for (int u = 0; u < cam.width; ++u) {
            const Eigen::Vector3d d = T.linear() * cam.BackProject(u, v, 1.0);
            Hit h;
            if (caster.Intersect(T.translation().cast<float>(), d.cast<float>(), 0.f, 45.f, &h) &&
                h.object >= 0 && scene.objects[static_cast<size_t>(h.object)].id == id) {
              ++n;
            }
          }
        }
        best = std::max(best, static_cast<double>(n) / (cam.width * cam.height));
      }
      return best;
    };
    EXPECT_GT(best_fraction(now, cs->scene, added.id), 0.03)
        << cs->scene.name << " added building not seen";
    EXPECT_GT(best_fraction(before, scenes.original, removed.id), 0.03)
        << cs->scene.name << " removed building not seen";
  }
}

}  // namespace
}  // namespace mapdelta::sim
