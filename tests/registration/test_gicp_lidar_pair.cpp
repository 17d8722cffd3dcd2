// GICP on a real pair of Velodyne scans (tests/data/registration/lidar_pair, small_gicp's
// example data): the reference transform is recovered within 5 cm and 1 degree.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <fstream>
#include <string>

#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/registration/gicp.hpp"
#include "mapdelta/common/registration/registration_gate.hpp"
#include "mapdelta/common/registration/se3_tangent.hpp"

namespace mapdelta {
namespace {

const std::string kDir = std::string(MAPDELTA_TEST_DATA_DIR) + "/registration/lidar_pair/";

SE3 ReadReference() {
  std::ifstream in(kDir + "T_target_source.txt");
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) in >> M(r, c);
  }
  EXPECT_TRUE(in) << "could not read 16 numbers from " << kDir << "T_target_source.txt";
  SE3 T;
  T.matrix() = M;
  // The file stores 6 significant digits: re-orthonormalize the rotation.
  T.linear() = Eigen::Quaterniond(M.topLeftCorner<3, 3>()).normalized().toRotationMatrix();
  return T;
}

constexpr double kDeg = M_PI / 180.0;

class LidarPair : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    params_.voxel_m = 0.25;
    params_.num_threads = 2;
    target_ = new GicpCloud(ReadCloud(kDir + "target.ply"), params_);
    source_ = new GicpCloud(ReadCloud(kDir + "source.ply"), params_);
  }
  static void TearDownTestSuite() {
    delete target_;
    delete source_;
  }
  static void ExpectNearReference(const SE3& init) {
    const SE3 reference = ReadReference();
    const RegistrationResult r = AlignGicp(*target_, *source_, init, params_);
    const double dt = (r.T_target_source.translation() - reference.translation()).norm();
    const double dr = RotationAngle(r.T_target_source, reference);
    EXPECT_TRUE(r.converged);
    EXPECT_LT(dt, 0.05) << "translation error (m)";
    EXPECT_LT(dr, 1.0 * kDeg) << "rotation error (rad)";
    EXPECT_GT(r.num_inliers, r.num_source_points / 2);
    const GateDecision gate = CheckRegistration(r, init);
    EXPECT_TRUE(gate.accepted) << gate.reason;
    std::printf(
        "lidar pair: %d iterations, %zu/%zu inliers, fitness %.3f m, error vs reference "
        "%.4f m %.4f deg, sigma(t) %.4f %.4f %.4f m\n",
        r.iterations, r.num_inliers, r.num_source_points, r.fitness_m, dt, dr / kDeg,
        std::sqrt(r.covariance(3, 3)), std::sqrt(r.covariance(4, 4)),
        std::sqrt(r.covariance(5, 5)));
  }
  static GicpParams params_;
  static GicpCloud* target_;
  static GicpCloud* source_;
};
GicpParams LidarPair::params_;
GicpCloud* LidarPair::target_ = nullptr;
GicpCloud* LidarPair::source_ = nullptr;

TEST_F(LidarPair, RecoversReferenceFromIdentity) { ExpectNearReference(SE3::Identity()); }

TEST_F(LidarPair, RecoversReferenceFromPerturbedGuess) {
  Vector6d delta;
  delta << 0.03, -0.04, 0.07, 1.2, -1.0, 0.3;  // ~5 degrees and ~1.6 m off the reference
  ExpectNearReference(RetractRight(ReadReference(), delta));
}

TEST_F(LidarPair, ConvergedGradientVanishes) {
  const RegistrationResult r = AlignGicp(*target_, *source_, SE3::Identity(), params_);
  // At the minimum b = J^T W r is ~0 relative to the information in H.
  const Vector6d step = r.H.ldlt().solve(r.b);
  EXPECT_LT(step.head<3>().norm(), 1e-3);
  EXPECT_LT(step.tail<3>().norm(), 1e-3);
  EXPECT_TRUE(r.covariance.allFinite());
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Matrix6d>(r.covariance).eigenvalues().minCoeff(), 0);
}

// Per-chunk sums in chunk order: the result does not depend on the thread count, bit for bit
// (also when both clouds are prepared side by side).
TEST_F(LidarPair, SameResultForAnyThreadCount) {
  const PointCloud target = ReadCloud(kDir + "target.ply");
  const PointCloud source = ReadCloud(kDir + "source.ply");
  GicpParams one = params_, two = params_;
  one.num_threads = 1;
  two.num_threads = 2;
  const RegistrationResult a = AlignGicp(target, source, SE3::Identity(), one);
  const RegistrationResult b = AlignGicp(target, source, SE3::Identity(), two);
  EXPECT_EQ(a.T_target_source.matrix(), b.T_target_source.matrix());
  EXPECT_EQ(a.covariance, b.covariance);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.num_inliers, b.num_inliers);
}

}  // namespace
}  // namespace mapdelta
