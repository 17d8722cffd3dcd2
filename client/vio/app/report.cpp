#include "report.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>

#include "mapdelta/common/ate.hpp"
#include "mapdelta/common/error.hpp"

namespace mapdelta::vio {
namespace {

size_t SegmentOf(int64_t t_ns, const std::vector<int64_t>& reset_t_ns) {
  return static_cast<size_t>(
      std::count_if(reset_t_ns.begin(), reset_t_ns.end(), [&](int64_t r) { return r < t_ns; }));
}

double WrapDeg(double a) {
  while (a > 180) a -= 360;
  while (a < -180) a += 360;
  return a;
}

constexpr double kDeg = 180.0 / M_PI;

// ZYX Euler angles (yaw, pitch, roll) in degrees.
Eigen::Vector3d YawPitchRoll(const Eigen::Matrix3d& R) {
  return kDeg * Eigen::Vector3d(std::atan2(R(1, 0), R(0, 0)),
                                std::asin(std::clamp(-R(2, 0), -1.0, 1.0)),
                                std::atan2(R(2, 1), R(2, 2)));
}

}  // namespace

std::vector<SegmentAte> AtePerSegment(const Trajectory& ground_truth, const Trajectory& estimate,
                                      const std::vector<int64_t>& reset_t_ns) {
  std::vector<Trajectory> segments(reset_t_ns.size() + 1);
  for (const auto& p : estimate) segments[SegmentOf(p.t_ns, reset_t_ns)].push_back(p);
  std::vector<SegmentAte> out;
  for (const auto& s : segments) {
    if (s.size() < 3) continue;
    SegmentAte a;
    a.t_begin_ns = s.front().t_ns;
    a.t_end_ns = s.back().t_ns;
    try {
      const AteResult r = ComputeAte(ground_truth, s);
      a.pairs = r.pairs;
      a.rmse = r.rmse;
      a.max = r.max;
    } catch (const Error&) {
      continue;  // fewer than 3 associated pairs: nothing to align
    }
    out.push_back(a);
  }
  return out;
}

AttitudeSummary WriteAttitudeErrors(const std::string& path, const Trajectory& ground_truth,
                                    const Trajectory& estimate,
                                    const std::vector<int64_t>& reset_t_ns, double window_s) {
  std::ofstream file;
  if (!path.empty()) {
    file.open(path);
    if (!file) throw Error(ErrorCode::kIo, path + ": cannot write attitude errors");
    file << "# t_s roll_err_deg pitch_err_deg yaw_err_deg(rel. segment start) tilt_err_deg\n";
  }
  AttitudeSummary summary;
  size_t segment = static_cast<size_t>(-1);
  int64_t segment_start = 0;
  double yaw_offset = 0;
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  for (const auto& p : estimate) {
    SE3 gt;
    if (!InterpolateAt(ground_truth, p.t_ns, &gt)) continue;
    const Eigen::Matrix3d Re = p.T.linear(), Rg = gt.linear();
    const Eigen::Vector3d e = YawPitchRoll(Re), g = YawPitchRoll(Rg);
    const size_t s = SegmentOf(p.t_ns, reset_t_ns);
    if (s != segment) {
      segment = s;
      segment_start = p.t_ns;
      yaw_offset = WrapDeg(g[0] - e[0]);
    }
    const double roll = WrapDeg(e[2] - g[2]), pitch = WrapDeg(e[1] - g[1]);
    const double yaw = WrapDeg(e[0] - g[0] + yaw_offset);
    const double tilt =
        kDeg * std::acos(std::clamp((Re.transpose() * z).dot(Rg.transpose() * z), -1.0, 1.0));
    const double t_s = 1e-9 * static_cast<double>(p.t_ns - estimate.front().t_ns);
    if (file) file << t_s << ' ' << roll << ' ' << pitch << ' ' << yaw << ' ' << tilt << '\n';
    const bool early = 1e-9 * static_cast<double>(p.t_ns - segment_start) < window_s;
    double& tilt_max = early ? summary.max_tilt_early_deg : summary.max_tilt_late_deg;
    double& yaw_max = early ? summary.max_yaw_early_deg : summary.max_yaw_late_deg;
    tilt_max = std::max(tilt_max, tilt);
    yaw_max = std::max(yaw_max, std::abs(yaw));
  }
  return summary;
}

}  // namespace mapdelta::vio
