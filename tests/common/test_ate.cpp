// ATE against evo's reference numbers on real TUM data, and Umeyama against Eigen's
// implementation and known transforms.
#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include <random>

#include "mapdelta/common/ate.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/trajectory_io.hpp"

namespace mapdelta {
namespace {

struct EvoReference {
  AteAlignment alignment;
  double rmse, mean, median, std, min, max, sse;
};

void ExpectRelative(double got, double expected, const char* what) {
  EXPECT_NEAR(got, expected, 1e-6 * std::abs(expected)) << what;
}

TEST(Ate, MatchesEvoOnTumFr2Desk) {
  const std::string dir = std::string(MAPDELTA_TEST_DATA_DIR) + "/tum_fr2_desk/";
  const Trajectory ref = ReadTrajectory(dir + "fr2_desk_groundtruth.txt");
  const Trajectory est = ReadTrajectory(dir + "fr2_desk_ORB.txt");
  ASSERT_EQ(ref.size(), 20957u);
  ASSERT_EQ(est.size(), 2893u);
  const EvoReference cases[] = {
      {AteAlignment::kSE3, 0.008118977562044912, 0.007491776870216138, 0.0074146298293169075,
       0.0031290695070393085, 0.00034963619840676515, 0.024299593694384707, 0.14330528992359753},
      {AteAlignment::kSim3, 0.006123163030157227, 0.005586197318706093, 0.005305225075852543,
       0.0025074937707529996, 0.00018979580960878624, 0.02147678556278729, 0.08151005482370433},
      {AteAlignment::kNone, 3.17399354190223, 2.9496938875994747, 2.594642464975095,
       1.1719816438389132, 1.4603442833644174, 5.066735062280106, 21901.386898776575},
  };
  for (const auto& c : cases) {
    const AteResult r = ComputeAte(ref, est, {c.alignment, 0.01});
    EXPECT_EQ(r.pairs, 2174u);
    ExpectRelative(r.rmse, c.rmse, "rmse");
    ExpectRelative(r.mean, c.mean, "mean");
    ExpectRelative(r.median, c.median, "median");
    ExpectRelative(r.std, c.std, "std");
    ExpectRelative(r.min, c.min, "min");
    ExpectRelative(r.max, c.max, "max");
    ExpectRelative(r.sse, c.sse, "sse");
  }
}

Eigen::Matrix3Xd RandomPoints(std::mt19937& rng, int n) {
  std::normal_distribution<double> g(0, 5);
  Eigen::Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) p.col(i) = Eigen::Vector3d(g(rng), g(rng), g(rng));
  return p;
}

TEST(Ate, UmeyamaRecoversKnownTransformAndMatchesEigen) {
  std::mt19937 rng(8);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Matrix3Xd source = RandomPoints(rng, 50);
    const Eigen::Matrix3d R = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
    const Eigen::Vector3d t(1.5 * trial, -2, 0.3);
    const double scale = 0.5 + 0.1 * trial;
    const Eigen::Matrix3Xd target = ((scale * R * source).colwise() + t).eval();
    const Similarity sim = Umeyama(source, target, true);
    EXPECT_TRUE(sim.R.isApprox(R, 1e-9));
    EXPECT_TRUE(sim.t.isApprox(t, 1e-9));
    EXPECT_NEAR(sim.scale, scale, 1e-9);
    // With noise, both SE(3) and Sim(3) agree with Eigen's independent implementation.
    Eigen::Matrix3Xd noisy = target + 0.1 * RandomPoints(rng, 50);
    for (const bool with_scale : {false, true}) {
      const Similarity ours = Umeyama(source, noisy, with_scale);
      const Eigen::Matrix4d eigen = Eigen::umeyama(source, noisy, with_scale);
      EXPECT_TRUE((ours.scale * ours.R).isApprox(eigen.topLeftCorner<3, 3>(), 1e-9));
      EXPECT_TRUE(ours.t.isApprox(eigen.topRightCorner<3, 1>(), 1e-9));
    }
  }
  EXPECT_THROW(Umeyama(Eigen::Matrix3Xd::Zero(3, 2), Eigen::Matrix3Xd::Zero(3, 2), false), Error);
}

TEST(Ate, SelfVersusTransformedIsZeroAndAssociationRespectsMaxDt) {
  std::mt19937 rng(4);
  Trajectory ref, moved, shifted;
  SE3 T_a_b = SE3::Identity();
  T_a_b.linear() = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
  T_a_b.translation() = Eigen::Vector3d(10, -3, 2);
  std::normal_distribution<double> g(0, 3);
  for (int i = 0; i < 100; ++i) {
    StampedPose p;
    p.t_ns = 1'000'000'000LL + i * 100'000'000LL;
    p.T.translation() = Eigen::Vector3d(g(rng), g(rng), g(rng));
    ref.push_back(p);
    moved.push_back({p.t_ns, T_a_b * p.T});
    shifted.push_back({p.t_ns + 20'000'000LL, p.T});  // 20 ms late
  }
  const AteResult se3 = ComputeAte(ref, moved, {AteAlignment::kSE3, 0.01});
  EXPECT_EQ(se3.pairs, 100u);
  EXPECT_LT(se3.rmse, 1e-9);
  EXPECT_LT(se3.max, 1e-9);
  EXPECT_GT(ComputeAte(ref, moved, {AteAlignment::kNone, 0.01}).rmse, 1.0);
  EXPECT_THROW(ComputeAte(ref, shifted, {AteAlignment::kSE3, 0.01}), Error);
  EXPECT_EQ(ComputeAte(ref, shifted, {AteAlignment::kNone, 0.025}).pairs, 100u);
}

}  // namespace
}  // namespace mapdelta
