#include "mapdelta/client/registration_report.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/registration/se3_tangent.hpp"

namespace mapdelta::client {

CovarianceCalibration CalibrateAgainst(const std::vector<RegistrationRecord>& records,
                                       const Trajectory& gt) {
  CovarianceCalibration c;
  double sum_e2[6] = {}, sum_var[6] = {};
  size_t within[6] = {};
  double nees = 0;
  std::vector<double> normalized;  // |e_i| / sigma_i over all axes
  for (const auto& r : records) {
    SE3 truth;
    if (!r.accepted || !InterpolateAt(gt, r.t_ns, &truth)) continue;
    const Vector6d e = LocalRight(truth, r.T_map_body);
    const Eigen::LDLT<Matrix6d> ldlt(r.covariance);
    if (ldlt.info() != Eigen::Success) continue;
    ++c.registrations;
    nees += e.dot(ldlt.solve(e));
    for (int i = 0; i < 6; ++i) {
      const double var = r.covariance(i, i);
      within[i] += std::abs(e[i]) <= 3.0 * std::sqrt(var);
      normalized.push_back(std::abs(e[i]) / std::sqrt(std::max(var, 1e-300)));
      sum_e2[i] += e[i] * e[i];
      sum_var[i] += var;
    }
  }
  if (c.registrations == 0) return c;
  const double n = static_cast<double>(c.registrations);
  size_t all = 0;
  for (int i = 0; i < 6; ++i) {
    c.within_3sigma[i] = within[i] / n;
    c.rms_over_sigma[i] = std::sqrt(sum_e2[i] / std::max(sum_var[i], 1e-300));
    all += within[i];
  }
  c.within_3sigma_all = all / (6.0 * n);
  c.mean_nees = nees / n;
  std::sort(normalized.begin(), normalized.end());
  const double q97 =
      normalized[std::min(normalized.size() - 1, static_cast<size_t>(0.97 * normalized.size()))];
  c.scale_for_97 = (q97 / 3.0) * (q97 / 3.0);
  return c;
}

void WriteRegistrationsCsv(const std::string& path,
                           const std::vector<RegistrationRecord>& records) {
  std::ofstream out(path);
  if (!out) throw Error(ErrorCode::kIo, path + ": cannot write");
  out << "t_ns,keyframe,accepted,fitness_m,inlier_fraction,x,y,z,qx,qy,qz,qw,"
         "sigma_rx,sigma_ry,sigma_rz,sigma_tx,sigma_ty,sigma_tz,cloud_keyframes,cloud_points,"
         "reason\n";
  out << std::setprecision(9);
  for (const auto& r : records) {
    const Eigen::Quaterniond q(r.T_map_body.linear());
    const Eigen::Vector3d& p = r.T_map_body.translation();
    out << r.t_ns << ',' << r.keyframe << ',' << (r.accepted ? 1 : 0) << ',' << r.fitness_m << ','
        << r.inlier_fraction << ',' << p.x() << ',' << p.y() << ',' << p.z() << ',' << q.x() << ','
        << q.y() << ',' << q.z() << ',' << q.w();
    for (int i = 0; i < 6; ++i) out << ',' << std::sqrt(std::max(0.0, r.covariance(i, i)));
    out << ',' << r.cloud_keyframes << ',' << r.cloud_points;
    std::string reason = r.reason;
    for (char& ch : reason) {
      if (ch == ',' || ch == '\n') ch = ';';
    }
    out << ',' << reason << '\n';
  }
  if (!out) throw Error(ErrorCode::kIo, path + ": write failed");
}

}  // namespace mapdelta::client
