#include "mapdelta/common/registration/se3_tangent.hpp"

namespace mapdelta {

SE3 RetractRight(const SE3& T, const Vector6d& delta) {
  SE3 out = SE3::Identity();
  out.linear() = T.linear() * ExpSO3(delta.head<3>());
  out.translation() = T.translation() + T.linear() * delta.tail<3>();
  return out;
}

Vector6d LocalRight(const SE3& T_ref, const SE3& T) {
  Vector6d delta;
  delta.head<3>() = LogSO3(T_ref.linear().transpose() * T.linear());
  delta.tail<3>() = T_ref.linear().transpose() * (T.translation() - T_ref.translation());
  return delta;
}

}  // namespace mapdelta
