// Covariance calibration: over many noisy trials with fresh samples of the simulated scene,
// per-axis errors (right-perturbation tangent vs ground truth) fall within 3 sigma of the
// reported covariance in about 97% of cases, and the mean NEES is near its expectation (6).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mapdelta/common/registration/gicp.hpp"
#include "mapdelta/common/registration/se3_tangent.hpp"
#include "synthetic_scene.hpp"

namespace mapdelta {
namespace {

TEST(GicpCovariance, CalibratedOnNoisyTrials) {
  constexpr int kTrials = 60;
  GicpParams params;
  params.voxel_m = 0.4;
  std::mt19937 rng(2024);
  std::normal_distribution<double> n(0, 1);
  int within = 0, axes = 0;
  double nees_sum = 0;
  Vector6d sq_error_sum = Vector6d::Zero(), variance_sum = Vector6d::Zero();
  for (int trial = 0; trial < kTrials; ++trial) {
    Vector6d truth_delta;
    for (int k = 0; k < 6; ++k) truth_delta(k) = n(rng);
    truth_delta.head<3>() *= 0.3;
    truth_delta.tail<3>() *= 3.0;
    const SE3 T_target_source = RetractRight(SE3::Identity(), truth_delta);
    const PointCloud target = test::SampleUrbanScene(30000, 0.02, rng);
    const PointCloud source =
        Transform(test::SampleUrbanScene(8000, 0.08, rng), T_target_source.inverse());
    Vector6d guess;
    for (int k = 0; k < 6; ++k) guess(k) = n(rng);
    guess.head<3>() *= 0.02;
    guess.tail<3>() *= 0.3;
    const RegistrationResult r =
        AlignGicp(target, source, RetractRight(T_target_source, guess), params);
    ASSERT_TRUE(r.converged) << "trial " << trial << ": " << r.iterations << " iterations, "
                             << r.num_inliers << " inliers";
    const Vector6d e = LocalRight(T_target_source, r.T_target_source);
    for (int k = 0; k < 6; ++k) {
      within += std::abs(e(k)) <= 3 * std::sqrt(r.covariance(k, k));
      ++axes;
    }
    nees_sum += e.dot(r.covariance.ldlt().solve(e));
    sq_error_sum += e.cwiseAbs2();
    variance_sum += r.covariance.diagonal();
  }
  const double fraction = static_cast<double>(within) / axes;
  const double mean_nees = nees_sum / kTrials;
  std::printf(
      "covariance calibration over %d trials: %.1f%% of per-axis errors within 3 sigma, "
      "mean NEES %.2f (expected 6)\n",
      kTrials, 100 * fraction, mean_nees);
  std::printf("per axis rms error / mean sigma: ");
  for (int k = 0; k < 6; ++k) {
    std::printf("%.2f ", std::sqrt(sq_error_sum(k) / variance_sum(k)));
  }
  std::printf("\n");
  EXPECT_GE(fraction, 0.93);
  // Not calibrated by being uselessly wide either.
  EXPECT_GT(mean_nees, 2.0);
  EXPECT_LT(mean_nees, 15.0);
}

}  // namespace
}  // namespace mapdelta
