// mapdelta-eval removed-breakdown on a scene built so that each cause happens where we know it:
// a near wall and a bigger far wall (nothing removed), one keyframe whose stereo depth has no
// depth on the left half (rays pass the near wall, and the far wall hidden behind it) and on
// the right half overshoots the near wall by 5 m. The paper's rule removes all of that falsely;
// the breakdown must name those causes, and the confident rule must not remove them.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <sstream>

#include "box_scene.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/keyframes.hpp"
#include "mapdelta/tools/commands.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta {
namespace {

using testing::Box;

struct Scene {
  std::string dir;
  std::vector<std::string> eval_args;  // removed-breakdown arguments of the paper-rule run
};

nlohmann::json ReadJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

size_t Row(const nlohmann::json& table, const std::string& bin, const char* column) {
  for (const auto& row : table) {
    if (row["bin"] == bin) return row[column].get<size_t>();
  }
  ADD_FAILURE() << "no bin " << bin;
  return 0;
}

Scene WriteScene(const std::string& name) {
  Scene s{mapdelta::testing::FreshTempDir("mapdelta_test_" + name).string(), {}};
  const std::vector<Box> boxes = {{{-3, -2, 10}, {3, 2, 10.4}}, {{-8, -5, 16}, {8, 5, 16.4}}};
  KeyframeFolder folder;
  folder.camera.width = 160;
  folder.camera.height = 100;
  folder.camera.fx = folder.camera.fy = 80;
  folder.camera.cx = 80;
  folder.camera.cy = 50;
  const DepthImage truth = testing::RenderDepth(folder.camera, SE3::Identity(), boxes);
  DepthImage stereo = truth;
  for (int v = 0; v < stereo.height; ++v) {
    for (int u = 0; u < stereo.width; ++u) {
      float& d = stereo.at(u, v);
      if (u < stereo.width / 2)
        d = 0.f;  // unmatched: no depth
      else if (d > 0.f && d < 11.f)
        d += 5.f;  // the near wall seen 5 m too far
    }
  }
  folder.keyframes.push_back({1000, SE3::Identity(), std::nullopt, stereo});
  WriteKeyframeFolder(s.dir + "/keyframes", folder);
  std::filesystem::create_directories(s.dir + "/gt");
  WriteDepthPng(s.dir + "/gt/1000.png", truth);
  const PointCloud prior = testing::SampleBoxSurfaces(boxes, 0.2);
  WriteCloud(s.dir + "/original.pcd", prior);
  WriteCloud(s.dir + "/changed.pcd", prior);  // nothing changed: every removal is false
  s.eval_args = {"--original",       s.dir + "/original.pcd",
                 "--changed",        s.dir + "/changed.pcd",
                 "--removed",        s.dir + "/paper/removed.pcd",
                 "--global",         s.dir + "/paper/global.pcd",
                 "--observed",       s.dir + "/paper/observed.bt",
                 "--keyframes",      s.dir + "/keyframes",
                 "--gt-depth",       s.dir + "/gt",
                 "--free-ray-bound", "0"};
  return s;
}

size_t Detect(const Scene& s, const std::string& rule) {
  std::ostringstream out;
  EXPECT_EQ(
      tools::RunDetect({"--prior", s.dir + "/original.pcd", "--keyframes", s.dir + "/keyframes",
                        "--out", s.dir + "/" + rule, "--free-space", rule},
                       out),
      0);
  return ReadJson(s.dir + "/" + rule + "/summary.json")["removed_points"].get<size_t>();
}

TEST(RemovedBreakdown, NamesNoDepthRaysHiddenPointsAndOvershoot) {
  const Scene s = WriteScene("removed_breakdown");
  ASSERT_GT(Detect(s, "paper"), 50u);
  std::vector<std::string> args = s.eval_args;
  args.insert(args.end(), {"--json", s.dir + "/breakdown.json"});
  std::ostringstream out;
  ASSERT_EQ(tools::RunEvalRemovedBreakdown(args, out), 0);
  const auto json = ReadJson(s.dir + "/breakdown.json");
  const size_t detected = json["detected_removed"], false_removed = json["false_removed"];
  EXPECT_EQ(detected, false_removed);  // nothing was removed in truth
  const auto& cause = json["tables"]["cause"];
  const size_t visible = Row(cause, "no-depth ray, point visible", "false");
  const size_t hidden = Row(cause, "no-depth ray, point hidden", "false");
  const size_t overshoot = Row(cause, "depth beyond it, overshoot", "false");
  EXPECT_GT(visible, 20u);    // the near wall's left half and the far wall's uncovered left part
  EXPECT_GT(hidden, 20u);     // the far wall behind the near wall's left half
  EXPECT_GT(overshoot, 20u);  // the near wall's right half
  EXPECT_EQ(Row(cause, "pose error (gone at GT poses)", "false"), 0u);
  EXPECT_GE(visible + hidden + overshoot, false_removed * 9 / 10);
  EXPECT_EQ(Row(json["tables"]["range_m"], "10-20", "false") +
                Row(json["tables"]["range_m"], "no ray", "false"),
            false_removed);
  EXPECT_NE(out.str().find("| cause | false removed |"), std::string::npos) << out.str();
  // With a ground-truth-pose run that reports none of them, every point is the pose's doing.
  WriteCloud(s.dir + "/none.pcd", PointCloud{Point(100, 100, 100)});
  args.insert(args.end(), {"--removed-at-gt-poses", s.dir + "/none.pcd"});
  ASSERT_EQ(tools::RunEvalRemovedBreakdown(args, out), 0);
  EXPECT_EQ(Row(ReadJson(s.dir + "/breakdown.json")["tables"]["cause"],
                "pose error (gone at GT poses)", "false"),
            false_removed);
}

TEST(RemovedBreakdown, ConfidentRuleDoesNotRemoveTheWalls) {
  const Scene s = WriteScene("removed_breakdown_confident");
  EXPECT_GT(Detect(s, "paper"), 50u);
  EXPECT_EQ(Detect(s, "confident"), 0u);  // the evidence of one keyframe, not three
}

}  // namespace
}  // namespace mapdelta
