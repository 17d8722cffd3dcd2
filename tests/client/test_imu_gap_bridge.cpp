// The IMU bridge across an odometry reset (imu_gap_bridge.hpp), on a synthetic car: 4 m/s
// along its x axis, turning 90 deg left in the middle of a 10 s gap (paper S1_dark's lost
// stretch), a 200 Hz gyro with a bias and white noise at EuRoC's density. The odometry after
// the gap is in a new frame (another yaw and origin, as a re-initialized VIO's).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mapdelta/client/imu_gap_bridge.hpp"
#include "mapdelta/client/odometry_source.hpp"
#include "mapdelta/client/pose_fusion.hpp"

using namespace mapdelta;
using namespace mapdelta::client;

namespace {

constexpr int64_t kSecond = 1'000'000'000;
const Eigen::Vector3d kGyroBias(0.004, -0.003, 0.006);  // rad/s

struct Car {
  double t_turn_start = 3.0, t_turn_end = 7.0;  // the 90 deg turn
  double stop_from = -1, stop_to = -1;          // optional stop: speed ramps to 0 and back
  double Yaw(double t) const {
    const double s = std::clamp((t - t_turn_start) / (t_turn_end - t_turn_start), 0.0, 1.0);
    return M_PI + 0.5 * M_PI * s;  // heading -x (180 deg), then -y (270 deg)
  }
  double YawRate(double t) const {
    return (t > t_turn_start && t < t_turn_end) ? 0.5 * M_PI / (t_turn_end - t_turn_start) : 0.0;
  }
  double Speed(double t) const {
    if (t <= stop_from || t >= stop_to) return 4.0;
    const double mid = 0.5 * (stop_from + stop_to);
    return 4.0 * std::abs(t - mid) / (mid - stop_from);
  }
  SE3 Pose(double t) const {  // integrated finely
    Eigen::Vector3d p(10, 20, 1);
    constexpr double dt = 1e-3;
    for (double u = 0; u < t - 1e-12; u += dt) {
      const double h = std::min(dt, t - u);
      p += Speed(u + 0.5 * h) *
           Eigen::Vector3d(std::cos(Yaw(u + 0.5 * h)), std::sin(Yaw(u + 0.5 * h)), 0) * h;
    }
    SE3 T = SE3::Identity();
    T.linear() = Eigen::AngleAxisd(Yaw(t), Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = p;
    return T;
  }
  Eigen::Vector3d Velocity(double t) const {
    return Speed(t) * Eigen::Vector3d(std::cos(Yaw(t)), std::sin(Yaw(t)), 0);
  }
  std::vector<ImuSample> Imu(double t0, double t1, uint32_t seed) const {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0, 1.7e-4 * std::sqrt(200.0));
    std::vector<ImuSample> out;
    for (int64_t t = static_cast<int64_t>(t0 * kSecond); t <= static_cast<int64_t>(t1 * kSecond);
         t += kSecond / 200) {
      ImuSample s;
      s.t_ns = t;
      s.gyro = Eigen::Vector3d(0, 0, YawRate(1e-9 * static_cast<double>(t))) + kGyroBias +
               Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      out.push_back(s);
    }
    return out;
  }
};

// The new segment's frame: 130 deg of yaw and 60 m away from the old one.
SE3 NewFromOld() {
  SE3 T = SE3::Identity();
  T.linear() = Eigen::AngleAxisd(130.0 * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(-60, 5, 0);
  return T;
}

struct Bridged {
  std::optional<OdometryBridge> bridge;
  SE3 truth;  // the true pose after the gap, in the old frame
};

Bridged BridgeAcross(const Car& car, double t_before, double t_after,
                     const std::vector<ImuSample>& imu) {
  const GapEnd before{static_cast<int64_t>(t_before * kSecond), car.Pose(t_before),
                      car.Velocity(t_before)};
  const SE3 new_from_old = NewFromOld();
  const GapEnd after{static_cast<int64_t>(t_after * kSecond), new_from_old * car.Pose(t_after),
                     new_from_old.linear() * car.Velocity(t_after)};
  return {BridgeGap(before, after, imu, Eigen::Matrix3d::Identity(), kGyroBias), car.Pose(t_after)};
}

double HeadingErrorDeg(const SE3& a, const SE3& b) {
  return LogSO3(a.linear().transpose() * b.linear()).norm() * 180 / M_PI;
}

}  // namespace

TEST(ImuGapBridge, CarriesTheHeadingAndPathThroughATurn) {
  const Car car;
  const Bridged out = BridgeAcross(car, 0.5, 10.5, car.Imu(0, 11, 1));
  ASSERT_TRUE(out.bridge.has_value());
  EXPECT_LT(HeadingErrorDeg(out.bridge->T_prev_odom_body, out.truth), 0.5);
  // Constant speed: the interpolated velocity is right, the path too.
  EXPECT_LT((out.bridge->T_prev_odom_body.translation() - out.truth.translation()).norm(), 0.5);
  // A constant-velocity prediction would run 40 m straight on: 28 m off at the turn's end.
  const SE3 straight =
      car.Pose(0.5) * MakeSE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(40, 0, 0));
  EXPECT_GT((straight.translation() - out.truth.translation()).norm(), 20.0);
}

TEST(ImuGapBridge, AStopDuringTheGapStaysWithinTheStatedUncertainty) {
  Car car;
  car.stop_from = 2.0;  // slows to a stop at 4.5 s, back to 4 m/s at 7 s
  car.stop_to = 7.0;
  const Bridged out = BridgeAcross(car, 0.5, 10.5, car.Imu(0, 11, 2));
  ASSERT_TRUE(out.bridge.has_value());
  EXPECT_LT(HeadingErrorDeg(out.bridge->T_prev_odom_body, out.truth), 0.5);
  const double error =
      (out.bridge->T_prev_odom_body.translation() - out.truth.translation()).norm();
  EXPECT_GT(error, 2.0);  // the speed profile was a guess ...
  const double sigma = std::sqrt(out.bridge->covariance(3, 3));
  EXPECT_LT(error, 3.0 * sigma) << "sigma " << sigma;        // ... and the covariance says so
  EXPECT_LT(std::sqrt(out.bridge->covariance(2, 2)), 0.05);  // the heading is known to ~2 deg
}

TEST(ImuGapBridge, NoBridgeWhenTheImuDoesNotCoverTheGap) {
  const Car car;
  std::vector<ImuSample> imu = car.Imu(0, 11, 3);
  EXPECT_FALSE(BridgeAcross(car, 0.5, 10.5, car.Imu(0, 6, 3)).bridge.has_value());  // ends early
  imu.erase(imu.begin() + 1000, imu.begin() + 1100);                                // 0.5 s hole
  EXPECT_FALSE(BridgeAcross(car, 0.5, 10.5, imu).bridge.has_value());
  EXPECT_FALSE(
      BridgeAcross(car, 10.5, 0.5, car.Imu(0, 11, 3)).bridge.has_value());  // time reversed
}

TEST(ImuGapBridge, TheFusionStartsABridgedSegmentAtTheBridge) {
  FusionConfig config;
  PoseFusion fusion(config);
  Matrix6 cov = Matrix6::Identity() * 0.01;
  const SE3 start = MakeSE3(Eigen::Quaterniond(Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitZ())),
                            Eigen::Vector3d(100, 50, 2));
  fusion.SetInitialPose(start, cov);
  fusion.AddKeyframe(0, SE3::Identity(), std::nullopt, 0);
  OdometryBridge bridge;
  bridge.T_prev_odom_body =
      MakeSE3(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ())),
              Eigen::Vector3d(30, 10, 0));
  bridge.covariance = Matrix6::Identity() * 4.0;
  const SE3 new_frame_pose = NewFromOld() * bridge.T_prev_odom_body;
  const size_t k = fusion.AddKeyframe(10 * kSecond, new_frame_pose, std::nullopt, 1, bridge);
  EXPECT_TRUE(fusion.SegmentBridged(k));
  const SE3 expected = start * bridge.T_prev_odom_body;
  EXPECT_LT((fusion.FusedPose(k).translation() - expected.translation()).norm(), 1e-9);
  EXPECT_LT(HeadingErrorDeg(fusion.FusedPose(k), expected), 1e-6);
  fusion.Optimize(10);  // held there by the bridge's prior until a registration anchors it
  EXPECT_LT((fusion.FusedPose(k).translation() - expected.translation()).norm(), 1e-6);
  // Without a bridge: constant velocity (here: standing still at the last pose).
  PoseFusion plain(config);
  plain.SetInitialPose(start, cov);
  plain.AddKeyframe(0, SE3::Identity(), std::nullopt, 0);
  const size_t j = plain.AddKeyframe(10 * kSecond, new_frame_pose, std::nullopt, 1);
  EXPECT_FALSE(plain.SegmentBridged(j));
  EXPECT_LT((plain.FusedPose(j).translation() - start.translation()).norm(), 1e-9);
}

namespace {

// The car as a VIO would report it: pose, velocity and gyro bias at every asked time.
class CarOdometry : public OdometrySource {
 public:
  explicit CarOdometry(const Car& car) : car_(car) {}
  std::optional<OdometrySample> At(int64_t t_ns, const StereoImages* /*images*/) override {
    const double t = 1e-9 * static_cast<double>(t_ns);
    OdometrySample s;
    s.T_odom_body = car_.Pose(t);
    s.v_odom = car_.Velocity(t);
    s.gyro_bias = kGyroBias;
    return s;
  }

 private:
  Car car_;
};

}  // namespace

TEST(ImuGapBridge, AnInjectedResetOverAVioBridgesItsFirstSampleOnly) {
  const Car car;
  CarOdometry inner(car);
  const std::vector<ImuSample> imu = car.Imu(0, 12, 4);
  InjectedResetOdometrySource reset(&inner, kSecond / 2, 10.0, NewFromOld(), &imu);
  std::vector<OdometrySample> after;
  for (int64_t t = 0; t <= 11 * kSecond; t += kSecond / 20) {
    if (auto s = reset.At(t, nullptr)) {
      EXPECT_FALSE(s->bridge.has_value() && s->segment == 0);
      if (s->segment == 1) after.push_back(*s);
    }
  }
  ASSERT_GE(after.size(), 2u);
  ASSERT_TRUE(after[0].bridge.has_value());
  EXPECT_FALSE(after[1].bridge.has_value());
  // The bridge is in the old frame: the inner (never reset) pose at the first sample after.
  const SE3 truth = car.Pose(10.5);
  EXPECT_LT(HeadingErrorDeg(after[0].bridge->T_prev_odom_body, truth), 0.5);
  EXPECT_LT((after[0].bridge->T_prev_odom_body.translation() - truth.translation()).norm(), 0.5);
  // Without the IMU, no bridge (the pipeline then predicts at constant velocity).
  CarOdometry inner2(car);
  InjectedResetOdometrySource no_imu(&inner2, kSecond / 2, 10.0, NewFromOld());
  for (int64_t t = 0; t <= 11 * kSecond; t += kSecond / 20) {
    if (auto s = no_imu.At(t, nullptr)) {
      EXPECT_FALSE(s->bridge.has_value());
    }
  }
}
