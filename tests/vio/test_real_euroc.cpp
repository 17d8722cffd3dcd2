// Real frames: the first 8 stereo pairs (0.35 s) of EuRoC V1_01_easy with their calibration and
// IMU (tests/data/euroc_v101_start, README there). Expectations are measured on these frames
// (client/vio/README.md, session 8) with margins; each says what it protects.
//  - Rectification of the real calibration: the published intrinsics, distortion and T_BS give
//    a rectified pair with a 0.110 m baseline, and stereo matches on the real images then lie on
//    the same row.
//  - Front end: features, tracks carried from frame to frame, stereo matches.
//  - Start at rest: the MAV stands still for these 0.35 s; the odometry initializes at rest
//    within 0.5 s of the first frame with the gyro bias of EuRoC's ground truth, and a tilt
//    against the ground truth that is the accelerometer's bias, not an error of the estimate
//    or of the ground truth's frame (see StartsAtRestWithTheGroundTruthGyroBias).
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/stereo_rectifier.hpp"
#include "mapdelta/vio/feature_tracker.hpp"
#include "mapdelta/vio/run_sequence.hpp"

using namespace mapdelta;

namespace {

const std::string kDir = std::string(MAPDELTA_TEST_DATA_DIR) + "/euroc_v101_start";

cv::Mat Read(const std::string& path) {
  cv::Mat m = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (m.empty()) throw std::runtime_error(path + ": cannot read");
  return m;
}

// EuRoC's ground-truth state at its first row (1.04 s after the first image; the MAV has not
// moved yet: 0.017 m/s): orientation of the body in the Vicon world, gyro and accel biases.
struct GroundTruthState {
  Eigen::Quaterniond q_world_body;
  Eigen::Vector3d bg, ba;
};

GroundTruthState FirstGroundTruthRow() {
  std::ifstream in(kDir + "/groundtruth_first_rows.csv");
  std::string line;
  while (std::getline(in, line) && line.rfind('#', 0) == 0) {
  }
  std::vector<double> v;
  std::stringstream ss(line);
  for (std::string cell; std::getline(ss, cell, ',');) v.push_back(std::stod(cell));
  if (v.size() != 17) throw std::runtime_error("groundtruth_first_rows.csv: expected 17 columns");
  return {Eigen::Quaterniond(v[4], v[5], v[6], v[7]).normalized(),
          {v[11], v[12], v[13]},
          {v[14], v[15], v[16]}};
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI;
}

// Measured on these frames (session 8: fx 436.235 px, row error 0.29 px, 142 features on the
// first frame, all tracks carried, 36 % with a stereo match; tilt against the ground truth:
// raw accelerometer 2.61 deg, with EuRoC's accelerometer bias removed 0.61 deg, estimate
// 2.65 deg; session 9, bounded front end: row error 0.28 px, 82 of 85 stereo matches within
// 1 px, 143 features on the first frame, 148 per frame, 58 % with a stereo match, RANSAC
// inliers 1.000), with margins.
constexpr double kFx = 436.2;
constexpr double kRowErrorMax = 0.5, kWithin1PxMin = 0.9;
constexpr int kFirstFeaturesMin = 120;
constexpr double kFeaturesPerFrameMin = 130;
constexpr double kCarriedMin = 0.98, kStereoMin = 0.5, kInlierMin = 0.99;
constexpr double kBiasFreeTiltMax = 1.0, kRawTilt = 2.6;

}  // namespace

TEST(RealEuroc, RectifiesThePublishedCalibration) {
  const EurocSequence seq = ReadEurocSequence(kDir);
  ASSERT_TRUE(seq.cam0.HasDistortion());
  ASSERT_FALSE(IsRectifiedPair(seq.cam0, seq.cam1));
  const StereoRectifier rect(seq.cam0, seq.cam1);
  EXPECT_TRUE(IsRectifiedPair(rect.cam0(), rect.cam1()));
  EXPECT_NEAR(rect.baseline_m(), 0.1101, 0.0005);  // |t| of the two T_BS
  EXPECT_NEAR(rect.cam0().intrinsics.fx, kFx, 0.5);
  // Stereo matches on the real rectified images lie on the row of their left feature.
  vio::FeatureTracker tracker;
  const auto frames = seq.StereoFrames();
  cv::Mat left, right;
  rect.Rectify(0, Read(frames[0].left_path), &left);
  rect.Rectify(1, Read(frames[0].right_path), &right);
  const auto features = tracker.Track(left, right);
  double row_error = 0;
  int stereo = 0, within_1px = 0;
  for (const auto& f : features) {
    if (!f.has_right) continue;
    const double e = std::abs(f.right_px.y() - f.left_px.y());
    row_error += e;
    within_1px += e <= 1.0 ? 1 : 0;
    ++stereo;
  }
  ASSERT_GT(stereo, 60);  // 84-95 on this frame
  std::printf(
      "measured: fx %.3f row error %.3f px over %d stereo matches of %zu features, %.3f within "
      "1 px\n",
      rect.cam0().intrinsics.fx, row_error / stereo, stereo, features.size(),
      static_cast<double>(within_1px) / stereo);
  EXPECT_LT(row_error / stereo, kRowErrorMax);
  // The epipolar rows agree to a pixel for (nearly) every match: a calibration read or applied
  // wrongly (e.g. T_BS inverted, distortion ignored) shifts whole rows by several pixels.
  EXPECT_GE(static_cast<double>(within_1px) / stereo, kWithin1PxMin);
}

// The eight pairs through the front end, as the odometry runs it (rectified once per image).
TEST(RealEuroc, FrontEndTracksTheRealFrames) {
  const EurocSequence seq = ReadEurocSequence(kDir);
  const StereoRectifier rect(seq.cam0, seq.cam1);
  vio::FeatureTracker tracker;
  const auto frames = seq.StereoFrames();
  ASSERT_EQ(frames.size(), 8u);
  long previous = 0, carried = 0, stereo = 0, features = 0, ransac_in = 0, ransac_out = 0;
  size_t last_count = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    cv::Mat left, right;
    rect.Rectify(0, Read(frames[i].left_path), &left);
    rect.Rectify(1, Read(frames[i].right_path), &right);
    const auto out = tracker.Track(left, right);
    if (i == 0) {
      EXPECT_GE(static_cast<int>(out.size()), kFirstFeaturesMin);
      last_count = out.size();
      continue;
    }
    previous += static_cast<long>(last_count);
    carried += tracker.last_stats().tracked;
    ransac_in += tracker.last_stats().tracked;
    ransac_out += tracker.last_stats().rejected_ransac;
    features += static_cast<long>(out.size());
    for (const auto& f : out) stereo += f.has_right ? 1 : 0;
    last_count = out.size();
  }
  const double inliers =
      static_cast<double>(ransac_in) / static_cast<double>(ransac_in + ransac_out);
  std::printf("measured: carried %.3f stereo %.3f features/frame %.1f RANSAC inliers %.4f\n",
              static_cast<double>(carried) / previous, static_cast<double>(stereo) / features,
              features / static_cast<double>(frames.size() - 1), inliers);
  EXPECT_GT(static_cast<double>(carried) / previous, kCarriedMin);
  EXPECT_GT(static_cast<double>(stereo) / features, kStereoMin);
  EXPECT_GE(features / static_cast<double>(frames.size() - 1), kFeaturesPerFrameMin);
  EXPECT_GT(inliers, kInlierMin);
}

// The odometry at rest: the MAV stands still (ground truth 1.04 s later: 0.017 m/s).
TEST(RealEuroc, StartsAtRestWithTheGroundTruthGyroBias) {
  const EurocSequence seq = ReadEurocSequence(kDir);
  vio::VioConfig config;
  config.init_solver_max_time_s = 1e3;  // converged, whatever the load
  const vio::SequenceRunResult run = vio::RunSequence(seq, config);
  ASSERT_FALSE(run.frames.empty());
  EXPECT_EQ(run.resets, 0);
  const auto frames = seq.StereoFrames();
  const double first_pose_s =
      1e-9 * static_cast<double>(run.frames.front().t_ns - frames.front().t_ns);
  EXPECT_LE(first_pose_s, 0.5);
  EXPECT_GE(first_pose_s, 0.25);  // the rest window
  const GroundTruthState gt = FirstGroundTruthRow();
  // Up (world +z) in the body frame: estimated, ground truth, and the accelerometer's own.
  const Eigen::Vector3d up_est =
      run.frames.front().T.linear().transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_gt = gt.q_world_body.conjugate() * Eigen::Vector3d::UnitZ();
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();
  for (const auto& s : seq.imu_samples) accel += s.accel;
  accel /= static_cast<double>(seq.imu_samples.size());
  // The frame question (issue 25): with EuRoC's own accelerometer bias removed, the mean
  // specific force points along the ground truth's z to kBiasFreeTiltMax: the Vicon world is
  // gravity-aligned. The raw reading is kRawTilt off it, and so is the estimate, which cannot
  // tell that bias from tilt at rest.
  std::printf(
      "measured: first pose %.3f s, tilt est %.3f raw accel %.3f bias-free %.3f est-vs-accel %.3f "
      "deg\n",
      first_pose_s, AngleDeg(up_est, up_gt), AngleDeg(accel, up_gt), AngleDeg(accel - gt.ba, up_gt),
      AngleDeg(up_est, accel));
  EXPECT_LT(AngleDeg(accel - gt.ba, up_gt), kBiasFreeTiltMax);
  EXPECT_NEAR(AngleDeg(accel, up_gt), kRawTilt, 0.3);
  EXPECT_NEAR(AngleDeg(up_est, up_gt), kRawTilt, 0.5);
  EXPECT_LT(AngleDeg(up_est, accel), 0.5);
}
