// Prior registration and start-up refinement on a synthetic street scene with analytic
// geometry: ground, building facades of different orientation, poles. The local cloud is the
// scene around the vehicle in its body frame with noise; the guess is off by a known amount.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "mapdelta/client/local_cloud.hpp"
#include "mapdelta/client/prior_registration.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/voxel_grid.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta::client {
namespace {

PointCloud Scene() {
  PointCloud scene;
  const auto box = [&](double x0, double y0, double sx, double sy, double h) {
    for (double z = 0; z <= h; z += 0.4) {
      for (double x = x0; x <= x0 + sx; x += 0.4) {
        scene.emplace_back(x, y0, z);
        scene.emplace_back(x, y0 + sy, z);
      }
      for (double y = y0; y <= y0 + sy; y += 0.4) {
        scene.emplace_back(x0, y, z);
        scene.emplace_back(x0 + sx, y, z);
      }
    }
  };
  for (double x = -60; x <= 60; x += 0.5) {
    for (double y = -60; y <= 60; y += 0.5) scene.emplace_back(x, y, 0.02 * x);  // sloped road
  }
  box(-40, 8, 20, 12, 12);
  box(-10, 10, 15, 8, 20);
  box(15, 7, 25, 15, 9);
  box(-35, -25, 18, 14, 15);
  box(5, -22, 10, 10, 25);
  box(25, -30, 20, 18, 6);
  for (double x = -50; x <= 50; x += 12) {  // poles along the road
    for (double z = 0; z <= 6; z += 0.3) scene.emplace_back(x, -5.0, z);
  }
  return scene;
}

// A corridor along x: flat ground, two long walls at y = +-6 m and poles every 2.5 m on both
// sides. A vehicle's local cloud fits it equally well every 2.5 m along x.
PointCloud Corridor() {
  PointCloud corridor;
  for (double x = -80; x <= 80; x += 0.4) {
    for (double y = -6; y <= 6; y += 0.4) corridor.emplace_back(x, y, 0.0);
    for (double z = 0; z <= 8; z += 0.4) {
      corridor.emplace_back(x, -6.0, z);
      corridor.emplace_back(x, 6.0, z);
    }
  }
  for (double x = -80; x <= 80; x += 2.5) {
    for (double z = 0; z <= 5; z += 0.3) {
      corridor.emplace_back(x, -4.0, z);
      corridor.emplace_back(x, 4.0, z);
    }
  }
  return corridor;
}

SE3 Pose(double x, double y, double yaw_deg) {
  SE3 T = SE3::Identity();
  T.linear() =
      Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, 2.0 + 0.02 * x);
  return T;
}

// What a vehicle at T_map_body would reconstruct: scene points within 40 m, body frame, noisy.
PointCloud LocalCloud(const PointCloud& scene, const SE3& T_map_body, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.f, 0.05f);
  const SE3 T_body_map = T_map_body.inverse();
  PointCloud local;
  for (const auto& p : scene) {
    if ((p.cast<double>() - T_map_body.translation()).head<2>().norm() > 40.0) continue;
    local.push_back((T_body_map * p.cast<double>()).cast<float>() +
                    Eigen::Vector3f(noise(rng), noise(rng), noise(rng)));
  }
  return VoxelDownsample(local, 0.4f);
}

SE3 Offset(const SE3& T, double dx, double dy, double dyaw_deg) {
  SE3 out = T;
  out.translation() += Eigen::Vector3d(dx, dy, 0.0);
  out.linear() = Eigen::AngleAxisd(dyaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()) * T.linear();
  return out;
}

class PriorRegistrationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    scene_ = Scene();
    path_ = mapdelta::testing::TempFilePath("mapdelta_client_prior.pcd").string();
    WriteCloud(path_, scene_);
  }
  PointCloud scene_;
  std::string path_;
};

TEST_F(PriorRegistrationTest, StartupRecoversTwoMetresAndFiveDegrees) {
  FilePriorSource prior(path_, 0.4);
  PriorRegistrar registrar(RegistrationConfig{}, &prior);
  const SE3 truth = Pose(3.0, -1.0, 20.0);
  const PointCloud local = LocalCloud(scene_, truth, 1);
  for (const auto& [dx, dy, dyaw] : std::vector<std::tuple<double, double, double>>{
           {2.0, 0.0, 5.0}, {-1.4, 1.4, -5.0}, {0.0, -2.0, 5.0}}) {
    const RegistrationOutcome r = registrar.RefineInitialPose(local, Offset(truth, dx, dy, dyaw));
    const double dt = (r.T_map_body.translation() - truth.translation()).norm();
    const double dr = RotationAngle(r.T_map_body, truth) * 180.0 / M_PI;
    std::printf(
        "start-up guess off by (%.1f, %.1f) m, %.0f deg -> %s, error %.3f m %.3f deg, "
        "fitness %.3f m, %.3f s\n",
        dx, dy, dyaw, r.reason.c_str(), dt, dr, r.fitness_m, r.seconds);
    EXPECT_TRUE(r.accepted) << r.reason;
    EXPECT_LT(dt, 0.1);
    EXPECT_LT(dr, 0.3);
    // The covariance is a real 6x6 and positive definite.
    EXPECT_GT(r.covariance.llt().matrixL().toDenseMatrix().diagonal().minCoeff(), 0.0);
  }
}

// A georeferenced copy of the prior (UTM 32N, float64 PLY): the source picks a local origin,
// hands out the same points relative to it, and the registration in that local frame lands
// on the truth as it does near (0, 0), to the millimetre.
TEST_F(PriorRegistrationTest, UtmPriorGivesTheSameRegistrationInItsLocalFrame) {
  const Eigen::Vector3d utm(500000, 5400000, 100);
  const std::string utm_path = mapdelta::testing::TempFilePath("mapdelta_client_utm.ply").string();
  WriteCloud(utm_path, scene_, CloudFrame{utm, "EPSG:32632"});
  FilePriorSource near_zero(path_, 0.4), georeferenced(utm_path, 0.4);
  EXPECT_EQ(near_zero.MapOrigin(), Eigen::Vector3d::Zero());
  // Middle of the extent rounded down to the 50 m grid; z is within the float32 bound.
  const Eigen::Vector3d origin = georeferenced.MapOrigin();
  EXPECT_EQ(origin, Eigen::Vector3d(500000, 5400000, 0));
  const Eigen::Vector3d shift = utm - origin;  // local of the copy = local near 0 + shift
  const SE3 truth = Pose(3.0, -1.0, 20.0);
  SE3 truth_utm = truth;
  truth_utm.translation() += shift;
  const PointCloud local = LocalCloud(scene_, truth, 1);
  PriorRegistrar a(RegistrationConfig{}, &near_zero), b(RegistrationConfig{}, &georeferenced);
  const RegistrationOutcome ra = a.RefineInitialPose(local, Offset(truth, 2.0, 0.0, 5.0));
  const RegistrationOutcome rb = b.RefineInitialPose(local, Offset(truth_utm, 2.0, 0.0, 5.0));
  ASSERT_TRUE(ra.accepted && rb.accepted) << ra.reason << " / " << rb.reason;
  EXPECT_LT((rb.T_map_body.translation() - shift - ra.T_map_body.translation()).norm(), 1e-3);
  EXPECT_LT(RotationAngle(ra.T_map_body, rb.T_map_body), 1e-4);
  // In map coordinates (local + origin) the copy's answer is the truth shifted into UTM.
  EXPECT_LT((rb.T_map_body.translation() + origin - (truth.translation() + utm)).norm(), 0.1);
}

TEST_F(PriorRegistrationTest, RelocalizationRecoversLargerDriftWithinItsLimits) {
  FilePriorSource prior(path_, 0.4);
  const RegistrationConfig config;
  PriorRegistrar registrar(config, &prior);
  const SE3 truth = Pose(-8.0, 1.0, 60.0);
  const PointCloud local = LocalCloud(scene_, truth, 4);
  const SE3 guess = Offset(truth, 4.0, -3.5, 10.0);  // 5.3 m, 10 deg: beyond the normal gate
  EXPECT_FALSE(registrar.Register(local, guess).accepted);
  const RegistrationOutcome r =
      registrar.RefineInitialPose(local, guess, config.relocalize_max_correction_m,
                                  config.relocalize_max_correction_deg * M_PI / 180.0);
  const double dt = (r.T_map_body.translation() - truth.translation()).norm();
  std::printf("re-localization from 5.3 m / 10 deg: %s, error %.3f m\n", r.reason.c_str(), dt);
  EXPECT_TRUE(r.accepted) << r.reason;
  EXPECT_LT(dt, 0.1);
}

TEST_F(PriorRegistrationTest, ReanchoringAmongHeadingHypothesesFindsTheTruth) {
  // After an odometry reset the heading is unknown (the vehicle turned during the gap): the
  // hypotheses are 12 headings at a position 3 m off; only the ones near the true heading can
  // converge, and the winner must be the truth.
  FilePriorSource prior(path_, 0.4);
  RegistrationConfig config;
  config.max_iterations = 25;  // hypotheses far off need not run to 50: keeps the test short
  PriorRegistrar registrar(config, &prior);
  const SE3 truth = Pose(2.0, -2.0, 175.0);
  const PointCloud local = LocalCloud(scene_, truth, 5);
  std::vector<SE3> guesses;
  for (int i = 0; i < 12; ++i) guesses.push_back(Offset(Pose(4.0, 0.0, 0.0), 0, 0, 30.0 * i));
  const RegistrationOutcome r =
      registrar.RefineAmongGuesses(local, guesses, config.relocalize_max_correction_m,
                                   config.relocalize_max_correction_deg * M_PI / 180.0);
  const double dt = (r.T_map_body.translation() - truth.translation()).norm();
  const double dr = RotationAngle(r.T_map_body, truth) * 180.0 / M_PI;
  std::printf("re-anchoring among 12 headings: %s, error %.3f m %.3f deg\n", r.reason.c_str(), dt,
              dr);
  EXPECT_TRUE(r.accepted) << r.reason;
  EXPECT_LT(dt, 0.1);
  EXPECT_LT(dr, 0.3);
  // Far from any prior structure the same search is rejected with a reason.
  std::vector<SE3> lost;
  for (int i = 0; i < 4; ++i) lost.push_back(Offset(Pose(5000.0, 0.0, 0.0), 0, 0, 90.0 * i));
  const RegistrationOutcome none = registrar.RefineAmongGuesses(local, lost, 8.0, 0.26);
  EXPECT_FALSE(none.accepted);
  EXPECT_NE(none.reason.find("none of 4"), std::string::npos) << none.reason;
}

// A gravity-aligned odometry (the VIO) knows the body's up direction; a registration that
// fits the prior but tilts the body against it by more than max_tilt_deg is a wrong match.
TEST_F(PriorRegistrationTest, RegistrationTiltedAgainstTheOdometrysGravityIsRejected) {
  FilePriorSource prior(path_, 0.4);
  const RegistrationConfig config;
  ASSERT_NEAR(config.max_tilt_deg, 6.0, 1e-12);
  PriorRegistrar registrar(config, &prior);
  const SE3 truth = Pose(-4.0, 2.0, 30.0);  // level: the body's up is the map's +z
  const PointCloud local = LocalCloud(scene_, truth, 3);
  const SE3 guess = Offset(truth, 0.5, -0.3, 1.0);
  const auto odometry_up = [](double tilt_deg) {
    return Eigen::Vector3d(Eigen::AngleAxisd(tilt_deg * M_PI / 180.0, Eigen::Vector3d::UnitX()) *
                           Eigen::Vector3d::UnitZ());
  };
  const RegistrationOutcome level = registrar.Register(local, guess, odometry_up(0.0));
  EXPECT_TRUE(level.accepted) << level.reason;
  const RegistrationOutcome slight = registrar.Register(local, guess, odometry_up(4.0));
  EXPECT_TRUE(slight.accepted) << slight.reason;
  const RegistrationOutcome tilted = registrar.Register(local, guess, odometry_up(10.0));
  EXPECT_FALSE(tilted.accepted);
  EXPECT_NE(tilted.reason.find("from the odometry's gravity > max_tilt 6 deg"), std::string::npos)
      << tilted.reason;
  // Without an odometry gravity there is nothing to check against.
  EXPECT_TRUE(registrar.Register(local, guess).accepted);
}

TEST_F(PriorRegistrationTest, BadGuessIsRejectedNotAccepted) {
  FilePriorSource prior(path_, 0.4);
  PriorRegistrar registrar(RegistrationConfig{}, &prior);
  const SE3 truth = Pose(-5.0, 2.0, -30.0);
  const PointCloud local = LocalCloud(scene_, truth, 2);
  // 12 m and 40 degrees off: whatever GICP converges to, the gate must not accept it as a fix
  // close to the truth unless it actually is.
  const RegistrationOutcome r = registrar.Register(local, Offset(truth, 12.0, -6.0, 40.0));
  const double dt = (r.T_map_body.translation() - truth.translation()).norm();
  std::printf("bad guess: %s (error %.2f m)\n", r.reason.c_str(), dt);
  EXPECT_FALSE(r.accepted && dt > 0.5) << r.reason;
  EXPECT_FALSE(r.accepted);
  EXPECT_FALSE(r.reason.empty());
  EXPECT_NE(r.reason, "accepted");
}

// Beyond covariance_full_points inliers the covariance is held as if the cloud had that many:
// the same registration with the limit above its inlier count gets GICP's covariance, with the
// limit at a quarter of it four times that (same pose: only the reported uncertainty differs).
TEST_F(PriorRegistrationTest, CovarianceStopsShrinkingBeyondTheFullPointCount) {
  FilePriorSource prior(path_, 0.4);
  const SE3 truth = Pose(10.0, 0.0, 90.0);
  const PointCloud local = LocalCloud(scene_, truth, 3);
  const SE3 guess = Offset(truth, 0.5, -0.3, 1.0);
  RegistrationConfig unlimited;
  unlimited.covariance_full_points = 1e9;
  PriorRegistrar unlimited_registrar(unlimited, &prior);
  const RegistrationOutcome a = unlimited_registrar.Register(local, guess);
  ASSERT_TRUE(a.accepted) << a.reason;
  const double inliers = a.inlier_fraction * static_cast<double>(a.source_points);
  ASSERT_GT(inliers, 400.0);
  RegistrationConfig limited;
  limited.covariance_full_points = inliers / 4.0;
  PriorRegistrar limited_registrar(limited, &prior);
  const RegistrationOutcome b = limited_registrar.Register(local, guess);
  ASSERT_TRUE(b.accepted) << b.reason;
  EXPECT_LT((a.T_map_body.translation() - b.T_map_body.translation()).norm(), 1e-9);
  EXPECT_TRUE(b.covariance.isApprox(4.0 * a.covariance, 1e-3))
      << "ratio " << b.covariance(3, 3) / a.covariance(3, 3);
}

TEST_F(PriorRegistrationTest, ASecondMinimumAlongTheTrackRaisesTheVarianceAlongIt) {
  const PointCloud corridor = Corridor();
  const std::string path = mapdelta::testing::TempFilePath("mapdelta_corridor.pcd").string();
  WriteCloud(path, corridor);
  FilePriorSource prior(path, 0.4);
  SE3 truth = SE3::Identity();
  truth.translation() = Eigen::Vector3d(1.0, 0.0, 2.0);
  const PointCloud local = LocalCloud(corridor, truth, 5);
  const SE3 guess = Offset(truth, 0.3, 0.1, 0.5);
  RegistrationConfig without, probing;
  without.ambiguity_probe_m = 0.0;
  probing.ambiguity_probe_m = 1.5;  // from +-1.5 m the next pole spacing (2.5 m) is nearer
  PriorRegistrar plain(without, &prior), probed(probing, &prior);
  const RegistrationOutcome a = plain.Register(local, guess);
  const RegistrationOutcome b = probed.Register(local, guess);
  ASSERT_TRUE(a.accepted) << a.reason;
  ASSERT_TRUE(b.accepted) << b.reason;
  EXPECT_LT((a.T_map_body.translation() - truth.translation()).norm(), 0.2);
  EXPECT_LT((a.T_map_body.translation() - b.T_map_body.translation()).norm(), 1e-9);
  // GICP's own covariance sees one sharp minimum; the probe finds the next one 2.5 m along x.
  EXPECT_LT(a.covariance(3, 3), 0.5);
  EXPECT_GT(b.covariance(3, 3), 2.0 * 2.0);
  // Across the corridor the walls leave one minimum: unchanged.
  EXPECT_DOUBLE_EQ(b.covariance(4, 4), a.covariance(4, 4));
}

TEST_F(PriorRegistrationTest, AnUnambiguousRegistrationKeepsItsCovarianceUnderTheProbe) {
  FilePriorSource prior(path_, 0.4);
  const SE3 truth = Pose(10.0, 0.0, 90.0);
  const PointCloud local = LocalCloud(scene_, truth, 3);
  const SE3 guess = Offset(truth, 0.5, -0.3, 1.0);
  RegistrationConfig without, probing;
  without.ambiguity_probe_m = 0.0;
  probing.ambiguity_probe_m = 1.0;
  PriorRegistrar plain(without, &prior), probed(probing, &prior);
  const RegistrationOutcome a = plain.Register(local, guess);
  const RegistrationOutcome b = probed.Register(local, guess);
  ASSERT_TRUE(a.accepted) << a.reason;
  ASSERT_TRUE(b.accepted) << b.reason;
  EXPECT_TRUE(b.covariance.isApprox(a.covariance, 1e-12));
}

TEST_F(PriorRegistrationTest, RegistrationOfNearbyGuessAndNoPriorReason) {
  FilePriorSource prior(path_, 0.4);
  PriorRegistrar registrar(RegistrationConfig{}, &prior);
  const SE3 truth = Pose(10.0, 0.0, 90.0);
  const RegistrationOutcome r =
      registrar.Register(LocalCloud(scene_, truth, 3), Offset(truth, 0.5, -0.3, 1.0));
  EXPECT_TRUE(r.accepted) << r.reason;
  EXPECT_LT((r.T_map_body.translation() - truth.translation()).norm(), 0.1);
  // Far outside the prior: rejected with a reason, no exception.
  const RegistrationOutcome none =
      registrar.Register(LocalCloud(scene_, truth, 3), Pose(5000, 5000, 0));
  EXPECT_FALSE(none.accepted);
  EXPECT_NE(none.reason.find("no prior"), std::string::npos) << none.reason;
}

TEST(LocalCloud, PointsLandInTheAnchorBodyFrame) {
  PinholeCamera cam;
  cam.width = 4;
  cam.height = 3;
  cam.fx = cam.fy = 2.0;
  cam.cx = 2.0;
  cam.cy = 1.0;
  DepthImage depth(4, 3);
  depth.at(2, 1) = 10.f;  // the principal point: (0, 0, 10) in the camera
  depth.at(0, 0) = 80.f;  // beyond max depth: dropped
  SE3 T_body_cam = SE3::Identity();
  T_body_cam.translation() = Eigen::Vector3d(0, 0, 1);
  LocalCloudConfig config;
  config.pixel_stride = 1;
  const SE3 anchor = Pose(0, 0, 0);
  const SE3 other = Pose(3, 0, 0);  // 3 m ahead along map x
  const PointCloud cloud = BuildLocalCloud({{other, &depth}}, anchor, cam, T_body_cam, config);
  ASSERT_EQ(cloud.size(), 1u);
  const Eigen::Vector3d expected =
      anchor.inverse() * other * T_body_cam * Eigen::Vector3d(0, 0, 10);
  EXPECT_LT((cloud[0].cast<double>() - expected).norm(), 1e-4);
}

}  // namespace
}  // namespace mapdelta::client
