// The client's stages on five simulated keyframes with ground truth (tests/data/client_sim):
// SGBM depth and the temporal filter against the simulator's exact depth, and the whole
// pipeline (start-up from a 2 m / 5 degree guess against an outdated prior) against GT poses.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "mapdelta/client/image.hpp"
#include "mapdelta/client/odometry_source.hpp"
#include "mapdelta/client/pipeline.hpp"
#include "mapdelta/client/stereo_depth.hpp"
#include "mapdelta/client/temporal_filter.hpp"
#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/keyframes.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta::client {
namespace {

const std::string kSimDir = std::string(MAPDELTA_TEST_DATA_DIR) + "/client_sim/";
const std::string kSequence = kSimDir + "S1_01_5kf";

struct DepthError {
  double rmse = 0, density = 0, bad_1m = 0;  // bad_1m: share of valid pixels off by > 1 m
};

DepthError Compare(const DepthImage& est, const DepthImage& gt, double max_depth) {
  double sq = 0;
  size_t n = 0, gt_n = 0, bad = 0;
  for (size_t k = 0; k < gt.depth_m.size(); ++k) {
    if (!(gt.depth_m[k] > 0.f) || gt.depth_m[k] > max_depth) continue;
    ++gt_n;
    if (!(est.depth_m[k] > 0.f)) continue;
    const double e = est.depth_m[k] - gt.depth_m[k];
    sq += e * e;
    bad += std::abs(e) > 1.0;
    ++n;
  }
  return {std::sqrt(sq / std::max<size_t>(n, 1)), static_cast<double>(n) / std::max<size_t>(gt_n, 1),
          static_cast<double>(bad) / std::max<size_t>(n, 1)};
}

TEST(SimKeyframes, TemporalFilterLowersSgbmDepthErrorAgainstGroundTruth) {
  const EurocSequence seq = ReadEurocSequence(kSequence);
  const StereoRig rig = MakeRectifiedStereoRig(seq);
  const auto frames = seq.StereoFrames();
  ASSERT_EQ(frames.size(), 5u);
  ASSERT_EQ(seq.depth0_images.size(), 5u);
  const StereoDepth stereo(StereoConfig{});
  std::vector<DepthImage> raw;
  std::vector<DepthFrame> window;
  raw.reserve(5);
  for (const auto& f : frames) {
    raw.push_back(stereo.ComputeDepth(ReadGrayImage(f.left_path), ReadGrayImage(f.right_path), rig));
  }
  for (size_t i = 0; i < 5; ++i) {
    SE3 T_map_body;
    ASSERT_TRUE(InterpolateAt(seq.groundtruth, frames[i].t_ns, &T_map_body));
    window.push_back({T_map_body * rig.T_body_cam0, &raw[i]});
  }
  const DepthImage gt = ReadDepthPng(seq.depth0_images[2].path);
  TemporalFilterConfig paper;  // the paper's alpha 4 (our default is 2)
  paper.alpha = 4;
  const DepthImage filtered = TemporalFilter(window, 2, rig.left, paper);
  const DepthError before = Compare(raw[2], gt, 50.0);
  const DepthError after = Compare(filtered, gt, 50.0);
  std::printf("sim keyframe, SGBM depth vs GT: RMSE %.3f m, >1 m %.3f, density %.3f\n", before.rmse,
              before.bad_1m, before.density);
  std::printf("after temporal filter (alpha 4): RMSE %.3f m, >1 m %.3f, density %.3f\n", after.rmse,
              after.bad_1m, after.density);
  EXPECT_LT(after.rmse, 0.7 * before.rmse);
  EXPECT_LT(after.bad_1m, before.bad_1m);
  // alpha 4 keeps only pixels all four neighbours confirm within 0.5 m (the paper's setting).
  EXPECT_GT(after.density, 0.10);
}

TEST(SimKeyframes, PipelineStartsFromARoughGuessAndWritesKeyframes) {
  const EurocSequence seq = ReadEurocSequence(kSequence);
  ClientConfig config;
  config.keyframes.min_translation_m = 0.5;  // the fixture's frames are ~1 m apart
  TrajectoryOdometrySource odometry(seq.groundtruth);
  FilePriorSource prior(kSimDir + "prior_original_crop.pcd", config.registration.prior_voxel_m);
  const auto out = mapdelta::testing::FreshTempDir("mapdelta_client_sim_kf");
  std::filesystem::remove_all(out);

  SE3 truth0;
  ASSERT_TRUE(InterpolateAt(seq.groundtruth, seq.StereoFrames()[0].t_ns, &truth0));
  SE3 guess = truth0;
  guess.translation() += Eigen::Vector3d(1.2, -1.6, 0.0);  // 2 m
  guess.linear() = Eigen::AngleAxisd(5.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()) * guess.linear();

  PipelineInputs in;
  in.sequence_dir = kSequence;
  in.odometry = &odometry;
  in.prior = &prior;
  in.keyframe_dir = out.string();
  in.initial_T_map_body = guess;
  const PipelineResult r = RunPipeline(config, in);
  EXPECT_EQ(r.keyframes, 5u);
  EXPECT_TRUE(r.startup_refined);
  ASSERT_EQ(r.fused_T_map_body.size(), 5u);
  for (size_t k = 0; k < 5; ++k) {
    SE3 truth;
    ASSERT_TRUE(InterpolateAt(seq.groundtruth, r.fused_T_map_body[k].t_ns, &truth));
    const double dt = (r.fused_T_map_body[k].T.translation() - truth.translation()).norm();
    const double dr = RotationAngle(r.fused_T_map_body[k].T, truth) * 180.0 / M_PI;
    const double vio = (r.vio_T_map_body[k].T.translation() - truth.translation()).norm();
    std::printf("keyframe %zu: fused error %.3f m %.2f deg (guess-anchored odometry %.3f m)\n", k, dt, dr, vio);
    EXPECT_LT(dt, 0.4);
    EXPECT_LT(dr, 1.5);
  }
  const KeyframeFolder folder = ReadKeyframeFolder(out.string());
  ASSERT_EQ(folder.keyframes.size(), 5u);
  // 400 px wide minus the unmatched band (128 disparities at 800 px -> 64 at 400 px).
  EXPECT_EQ(folder.camera.width, 400 - 64);
  EXPECT_DOUBLE_EQ(folder.camera.cx, MakeRectifiedStereoRig(seq).left.cx - 64);
  EXPECT_GT(folder.keyframes[2].depth.CountValid(), 1000u);
}

}  // namespace
}  // namespace mapdelta::client
