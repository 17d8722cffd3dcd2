// GICP on simulated urban-like local clouds with analytic ground truth: injected offsets up to
// 2 m and 5 degrees are recovered; a bad guess (15 m off) or a cloud from elsewhere is
// rejected by the gate; invalid input gives named errors or a non-converged result.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/registration/gicp.hpp"
#include "mapdelta/common/registration/registration_gate.hpp"
#include "mapdelta/common/registration/se3_tangent.hpp"
#include "mapdelta/common/voxel_grid.hpp"
#include "synthetic_scene.hpp"

namespace mapdelta {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The client's settings: local clouds voxelized at 0.4 m.
GicpParams ClientParams() {
  GicpParams p;
  p.voxel_m = 0.4;
  return p;
}

struct Scene {
  SE3 T_target_source;  // ground truth
  GicpCloud target;
  PointCloud source;  // in the source frame
};

Scene MakeScene(uint32_t seed) {
  std::mt19937 rng(seed);
  // The source frame: a vehicle pose in the map, so source coordinates differ from the target's.
  SE3 T_target_source = SE3::Identity();
  T_target_source.linear() = ExpSO3(Eigen::Vector3d(0.02, -0.01, 0.7));
  T_target_source.translation() = Eigen::Vector3d(3.0, -2.0, 1.5);
  const PointCloud target = test::SampleUrbanScene(60000, 0.02, rng);
  const PointCloud source_in_target = test::SampleUrbanScene(20000, 0.05, rng);
  return {T_target_source, GicpCloud(target, ClientParams()),
          Transform(source_in_target, T_target_source.inverse())};
}

const Scene& SharedScene() {
  static const Scene scene = MakeScene(42);
  return scene;
}

struct Offset {
  Eigen::Vector3d rotation_axis;
  double angle_rad;
  Eigen::Vector3d translation_m;  // in the target (map) frame
};

SE3 Perturb(const SE3& T, const Offset& o) {
  SE3 out = T;
  out.linear() = ExpSO3(o.rotation_axis.normalized() * o.angle_rad) * T.linear();
  out.translation() += o.translation_m;
  return out;
}

class InjectedOffset : public ::testing::TestWithParam<Offset> {};

TEST_P(InjectedOffset, IsRecoveredAndAccepted) {
  const Scene& scene = SharedScene();
  const SE3 init = Perturb(scene.T_target_source, GetParam());
  const RegistrationResult r = AlignGicp(scene.target, scene.source, init, ClientParams());
  const double dt = (r.T_target_source.translation() - scene.T_target_source.translation()).norm();
  const double dr = RotationAngle(r.T_target_source, scene.T_target_source);
  EXPECT_TRUE(r.converged);
  EXPECT_LT(dt, 0.05) << "translation error, m";
  EXPECT_LT(dr, 0.3 * kDeg) << "rotation error, rad";
  const GateDecision gate = CheckRegistration(r, init);
  EXPECT_TRUE(gate.accepted) << gate.reason;
  std::printf("offset: inliers %zu/%zu fitness %.3f error/inlier %.2f\n", r.num_inliers,
              r.num_source_points, r.fitness_m, r.error / r.num_inliers);
}

INSTANTIATE_TEST_SUITE_P(UpTo2mAnd5deg, InjectedOffset,
                         ::testing::Values(Offset{{0, 0, 1}, 5 * kDeg, {2.0, 0, 0}},
                                           Offset{{0, 0, 1}, -5 * kDeg, {0, -2.0, 0}},
                                           Offset{{1, 1, 0}, 5 * kDeg, {1.2, 1.2, 0.8}},
                                           Offset{{1, -2, 3}, 4 * kDeg, {-1.4, 1.0, -0.9}},
                                           Offset{{0, 1, 0}, 3 * kDeg, {0, 0, 2.0}}));

// A sparse, noisy source (a dark scene's stereo: a few hundred points over the whole patch)
// against a dense prior, as the client registers it (both voxelized at 0.4 m, k-nearest
// covariances). The source's 20 nearest neighbours span several surfaces, so its normals are
// noise, and GICP's combined covariance loses the prior's plane; taken as points against the
// prior's planes (source_as_points) the same clouds register closer to the truth.
TEST(GicpSparseSource, PointsAgainstThePriorsPlanesBeatGicpNormals) {
  std::mt19937 rng(7);
  GicpParams gicp;
  gicp.voxel_m = 0;
  gicp.covariance_neighborhood = CovarianceNeighborhood::kKNearest;
  GicpParams points = gicp;
  points.source_as_points = true;
  const GicpCloud target(VoxelDownsample(test::SampleUrbanScene(60000, 0.02, rng), 0.4f), gicp);
  double error_gicp = 0, error_points = 0;
  const int trials = 12;
  for (int trial = 0; trial < trials; ++trial) {
    const PointCloud source = test::SampleUrbanScene(300, 0.15, rng);  // in the target frame
    const SE3 init = Perturb(SE3::Identity(), {{0, 0, 1}, 2 * kDeg, {0.8, -0.6, 0.2}});
    const auto error = [&](const GicpParams& p) {
      const RegistrationResult r = AlignGicp(target, source, init, p);
      return r.T_target_source.translation().norm();
    };
    error_gicp += error(gicp) / trials;
    error_points += error(points) / trials;
  }
  std::printf("sparse source: mean translation error GICP %.3f m, points %.3f m\n", error_gicp,
              error_points);
  EXPECT_LT(error_points, 0.7 * error_gicp);
}

TEST(GicpGate, FifteenMetresOffIsRejected) {
  const Scene& scene = SharedScene();
  for (const Eigen::Vector3d& t : {Eigen::Vector3d(15, 0, 0), Eigen::Vector3d(-9, 12, 0)}) {
    const SE3 init = Perturb(scene.T_target_source, {{0, 0, 1}, 0.0, t});
    const RegistrationResult r = AlignGicp(scene.target, scene.source, init, ClientParams());
    const GateDecision gate = CheckRegistration(r, init);
    EXPECT_FALSE(gate.accepted) << "accepted with correction " << gate.correction_m << " m";
    const double dt =
        (r.T_target_source.translation() - scene.T_target_source.translation()).norm();
    std::printf(
        "15 m off: rejected=%d (%s), result %.2f m from truth, inliers %zu/%zu fitness %.3f "
        "error/inlier %.2f\n",
        !gate.accepted, gate.reason.c_str(), dt, r.num_inliers, r.num_source_points, r.fitness_m,
        r.error / r.num_inliers);
  }
}

TEST(GicpGate, CloudFromElsewhereIsRejected) {
  // A source from a different scene (same generator moved 200 m away) has no overlap.
  const Scene& scene = SharedScene();
  std::mt19937 rng(5);
  SE3 far = SE3::Identity();
  far.translation() = Eigen::Vector3d(200, 0, 0);
  const PointCloud elsewhere = Transform(test::SampleUrbanScene(5000, 0.05, rng), far);
  const RegistrationResult r = AlignGicp(scene.target, elsewhere, SE3::Identity(), ClientParams());
  const GateDecision gate = CheckRegistration(r, SE3::Identity());
  EXPECT_FALSE(gate.accepted);
  EXPECT_FALSE(gate.reason.empty());
}

TEST(GicpGate, ChecksEachField) {
  RegistrationResult good;
  good.converged = true;
  good.num_inliers = 900;
  good.num_source_points = 1000;
  good.fitness_m = 0.2;
  good.covariance = Matrix6d::Identity() * 1e-4;
  EXPECT_TRUE(CheckRegistration(good, SE3::Identity()).accepted);
  auto rejected_because = [&](RegistrationResult r) {
    const GateDecision d = CheckRegistration(r, SE3::Identity());
    EXPECT_FALSE(d.accepted);
    return d.reason;
  };
  RegistrationResult r = good;
  r.converged = false;
  EXPECT_NE(rejected_because(r).find("not converged"), std::string::npos);
  r = good;
  r.fitness_m = 1.5;
  EXPECT_NE(rejected_because(r).find("fitness"), std::string::npos);
  r = good;
  r.num_inliers = 100;
  EXPECT_NE(rejected_because(r).find("inlier fraction"), std::string::npos);
  r = good;
  r.T_target_source.translation() = Eigen::Vector3d(0, 4.5, 0);
  EXPECT_NE(rejected_because(r).find("correction"), std::string::npos);
  r = good;
  r.T_target_source.linear() = ExpSO3(Eigen::Vector3d(0, 0, 0.3));
  EXPECT_NE(rejected_because(r).find("rotation correction"), std::string::npos);
  r = good;
  r.covariance(2, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(rejected_because(r).find("covariance"), std::string::npos);
}

TEST(GicpInput, BadParametersAndCloudsAreNamed) {
  GicpParams p;
  p.k_neighbors = 2;
  try {
    ValidateGicpParams(p);
    FAIL() << "k_neighbors = 2 accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("k_neighbors"), std::string::npos);
  }
  SE3 nan_pose = SE3::Identity();
  nan_pose.translation().x() = std::numeric_limits<double>::quiet_NaN();
  const PointCloud few = {Point(0, 0, 0), Point(1, 0, 0)};
  EXPECT_THROW(AlignGicp(few, few, nan_pose, GicpParams{}), Error);
  // Too few points or only non-finite points: a non-converged result, not a crash.
  const RegistrationResult r = AlignGicp(few, few, SE3::Identity(), GicpParams{});
  EXPECT_FALSE(r.converged);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const PointCloud bad(100, Point(nan, 0, 0));
  EXPECT_FALSE(AlignGicp(bad, bad, SE3::Identity(), GicpParams{}).converged);
  EXPECT_FALSE(AlignGicp(PointCloud{}, PointCloud{}, SE3::Identity(), GicpParams{}).converged);
}

}  // namespace
}  // namespace mapdelta
