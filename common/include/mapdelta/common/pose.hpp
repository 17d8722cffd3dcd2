#pragma once
// Rigid transforms and timestamped poses. Frames are named in variables: T_a_b maps points
// from frame b into frame a (p_a = T_a_b * p_b). Quaternions are Hamilton, as Eigen's.
// Time is int64 nanoseconds (t_ns), as EuRoC.
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace mapdelta {

using SE3 = Eigen::Isometry3d;

struct StampedPose {
  int64_t t_ns = 0;
  SE3 T = SE3::Identity();  // the frames are named by the container (e.g. T_map_body)
};
using Trajectory = std::vector<StampedPose>;

SE3 MakeSE3(const Eigen::Quaterniond& q, const Eigen::Vector3d& t);
// Rotation vector (axis * angle) exponential / logarithm.
Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& omega);
Eigen::Vector3d LogSO3(const Eigen::Matrix3d& R);
// Angle of the relative rotation between two transforms, radians.
double RotationAngle(const SE3& a, const SE3& b);
// Linear position / slerp rotation interpolation at fraction s in [0,1].
SE3 Interpolate(const SE3& a, const SE3& b, double s);
// Pose at t_ns by interpolation in a time-sorted trajectory; false if outside its span.
bool InterpolateAt(const Trajectory& trajectory, int64_t t_ns, SE3* T);
// True if every entry is finite and the rotation is orthonormal within tolerance.
bool IsValidPose(const SE3& T, double tolerance = 1e-6);

}  // namespace mapdelta
