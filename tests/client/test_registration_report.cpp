// Covariance calibration report against an analytic oracle: registrations drawn from their
// stated covariance around the ground truth are calibrated (~99.7% within 3 sigma, NEES ~6);
// the same errors with a 10x too small sigma are not.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <random>

#include "mapdelta/client/registration_report.hpp"
#include "mapdelta/common/registration/se3_tangent.hpp"

namespace mapdelta::client {
namespace {

TEST(RegistrationReport, CalibrationOfSampledErrors) {
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  Trajectory gt;
  std::vector<RegistrationRecord> records, overconfident;
  Matrix6d cov = Matrix6d::Zero();
  cov.diagonal() << 1e-5, 2e-5, 4e-4, 0.01, 0.04, 0.0025;
  cov(3, 4) = cov(4, 3) = 0.01;  // correlated x-y, still positive definite
  const Matrix6d L = cov.llt().matrixL();
  for (int k = 0; k < 400; ++k) {
    SE3 T = SE3::Identity();
    T.linear() = ExpSO3(Eigen::Vector3d(0.01 * k, -0.02, 0.003 * k));
    T.translation() = Eigen::Vector3d(k, 0.5 * k, 3);
    gt.push_back({static_cast<int64_t>(k) * 1'000'000'000, T});
    Vector6d z;
    for (int i = 0; i < 6; ++i) z[i] = normal(rng);
    RegistrationRecord r;
    r.t_ns = gt.back().t_ns;
    r.accepted = true;
    r.T_map_body = RetractRight(T, L * z);
    r.covariance = cov;
    records.push_back(r);
    r.covariance = cov * 0.01;
    overconfident.push_back(r);
  }
  RegistrationRecord rejected;  // rejected attempts do not count
  rejected.t_ns = 5'000'000'000;
  rejected.T_map_body.translation() = Eigen::Vector3d(1000, 0, 0);
  records.push_back(rejected);

  const CovarianceCalibration c = CalibrateAgainst(records, gt);
  EXPECT_EQ(c.registrations, 400u);
  EXPECT_GT(c.within_3sigma_all, 0.98);
  EXPECT_NEAR(c.mean_nees, 6.0, 1.0);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(c.rms_over_sigma[i], 1.0, 0.15) << i;
  const CovarianceCalibration o = CalibrateAgainst(overconfident, gt);
  EXPECT_LT(o.within_3sigma_all, 0.5);
  EXPECT_GT(o.mean_nees, 100.0);
  // Inflating the overconfident covariance by the suggested factor calibrates it.
  EXPECT_NEAR(c.scale_for_97, 0.5, 0.3);  // ~2.17 sigma is the 97th percentile of |N(0,1)|
  EXPECT_NEAR(o.scale_for_97, 100.0 * c.scale_for_97, 1e-6 * o.scale_for_97);
}

}  // namespace
}  // namespace mapdelta::client
