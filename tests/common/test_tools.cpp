// The tools' commands end to end: mapdelta-detect on the box world written to disk, then
// mapdelta-eval changes on its outputs; ate on TUM data; bad input names the file.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

#include "box_scene.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/trajectory_io.hpp"
#include "mapdelta/tools/commands.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta {
namespace {

std::string TempDir(const std::string& name) {
  return mapdelta::testing::FreshTempDir("mapdelta_test_" + name).string();
}

nlohmann::json ReadJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

TEST(Tools, DetectThenEvaluateTheBoxWorld) {
  const std::string dir = TempDir("tools_e2e");
  const testing::BoxWorld world = testing::MakeBoxWorld();
  WriteKeyframeFolder(dir + "/keyframes", world.keyframes);
  WriteCloud(dir + "/original.pcd", testing::SampleBoxSurfaces(world.original, 0.3));
  WriteCloud(dir + "/changed.ply", testing::SampleBoxSurfaces(world.changed, 0.3));
  std::ostringstream out;
  ASSERT_EQ(tools::RunDetect({"--prior", dir + "/original.pcd", "--keyframes", dir + "/keyframes",
                              "--out", dir + "/out"},
                             out),
            0);
  const auto summary = ReadJson(dir + "/out/summary.json");
  EXPECT_EQ(summary["keyframes"], 24);
  EXPECT_GT(summary["new_points"].get<int>(), 100);
  ASSERT_EQ(
      tools::RunEvalChanges({"--original", dir + "/original.pcd", "--changed", dir + "/changed.ply",
                             "--new", dir + "/out/new.pcd", "--removed", dir + "/out/removed.pcd",
                             "--global", dir + "/out/global.pcd", "--observed",
                             dir + "/out/observed.bt", "--json", dir + "/metrics.json"},
                            out),
      0);
  const auto metrics = ReadJson(dir + "/metrics.json");
  for (const char* key : {"R_new", "P_new", "R_rm", "P_rm"}) {
    EXPECT_GE(metrics["paper"][key].get<double>(), 0.95) << key;
  }
  EXPECT_NE(out.str().find("reference_variant: R_new"), std::string::npos);
  // The same detection written as LAS (map teams' format): the same points, to the millimetre.
  ASSERT_EQ(tools::RunDetect({"--prior", dir + "/original.pcd", "--keyframes", dir + "/keyframes",
                              "--out", dir + "/las", "--format", "las"},
                             out),
            0);
  const PointCloud new_pcd = ReadCloud(dir + "/out/new.pcd"),
                   new_las = ReadCloud(dir + "/las/new.las");
  ASSERT_EQ(new_las.size(), new_pcd.size());
  for (size_t i = 0; i < new_pcd.size(); ++i) {
    EXPECT_LE((new_las[i] - new_pcd[i]).cwiseAbs().maxCoeff(), 0.0006) << i;
  }
}

TEST(Tools, AteCommandPrintsEvoNumbersAndJson) {
  const std::string data = std::string(MAPDELTA_TEST_DATA_DIR) + "/tum_fr2_desk/";
  const std::string json = TempDir("tools_ate") + "/ate.json";
  std::ostringstream out;
  ASSERT_EQ(tools::RunEvalAte({data + "fr2_desk_groundtruth.txt", data + "fr2_desk_ORB.txt",
                               "--align", "sim3", "--json", json},
                              out),
            0);
  EXPECT_NE(out.str().find("pairs  2174"), std::string::npos) << out.str();
  EXPECT_NEAR(ReadJson(json)["rmse"].get<double>(), 0.006123163030157227, 1e-9);
}

TEST(Tools, AteReadsEurocCsvAgainstTum) {
  const std::string data = std::string(MAPDELTA_TEST_DATA_DIR) + "/tum_fr2_desk/fr2_desk_ORB.txt";
  const std::string csv = TempDir("tools_euroc") + "/orb.csv";
  {
    std::ofstream out(csv);
    out << "#timestamp [ns],p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y "
           "[],q_RS_z []\n";
    out.precision(12);
    for (const auto& pose : ReadTrajectory(data)) {
      const Eigen::Quaterniond q(pose.T.linear());
      const Eigen::Vector3d t = pose.T.translation();
      out << pose.t_ns << ',' << t.x() << ',' << t.y() << ',' << t.z() << ',' << q.w() << ','
          << q.x() << ',' << q.y() << ',' << q.z() << '\n';
    }
  }
  std::ostringstream out;
  ASSERT_EQ(tools::RunEvalAte({csv, data, "--align", "none", "--max-dt", "0"}, out), 0);
  EXPECT_NE(out.str().find("pairs  2893"), std::string::npos) << out.str();
  EXPECT_NE(out.str().find("max    0\n"), std::string::npos) << out.str();
}

std::string ErrorOf(const std::function<void()>& run) {
  try {
    run();
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(Tools, BadInputNamesTheFileOrOption) {
  const std::string dir = TempDir("tools_bad");
  std::ostringstream out;
  std::ofstream(dir + "/bad.txt") << "1 2 3\n";
  EXPECT_NE(ErrorOf([&] {
              tools::RunEvalAte({dir + "/bad.txt", dir + "/bad.txt"}, out);
            }).find("bad.txt:1"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] {
              tools::RunEvalAte({"a", "b", "--align", "se4"}, out);
            }).find("--align"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] {
              tools::RunDetect({"--prior", "x.pcd"}, out);
            }).find("--keyframes"),
            std::string::npos);
  WriteCloud(dir + "/empty.pcd", {});
  std::filesystem::create_directories(dir + "/kf");
  EXPECT_NE(ErrorOf([&] {
              tools::RunDetect(
                  {"--prior", dir + "/empty.pcd", "--keyframes", dir + "/kf", "--out", dir}, out);
            }).find("empty.pcd: prior cloud is empty"),
            std::string::npos);
  // A depth image of the wrong size deep inside a streamed folder: named, no crash.
  testing::BoxWorld world = testing::MakeBoxWorld();
  world.keyframes.keyframes.resize(3);
  WriteKeyframeFolder(dir + "/kf3", world.keyframes);
  WriteDepthPng(dir + "/kf3/depth/2000000000.png", DepthImage(7, 5));
  WriteCloud(dir + "/prior.pcd", testing::SampleBoxSurfaces(world.original, 1.0));
  const std::string message = ErrorOf([&] {
    tools::RunDetect(
        {"--prior", dir + "/prior.pcd", "--keyframes", dir + "/kf3", "--out", dir + "/o"}, out);
  });
  EXPECT_NE(message.find("2000000000.png: image is 7x5, camera.yaml says 200x150"),
            std::string::npos)
      << message;
  EXPECT_NE(ErrorOf([&] {
              tools::RunDetect(
                  {"--prior", dir + "/x.pcd", "--keyframes", dir, "--out", dir, "--th-ch", "abc"},
                  out);
            }).find("--th-ch"),
            std::string::npos);
}

}  // namespace
}  // namespace mapdelta
