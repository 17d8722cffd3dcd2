#pragma once
// The pose tangent used by registration and fusion covariances: delta = [rotation(3),
// translation(3)] applied on the right, T (+) delta = (R * ExpSO3(w), t + R * v). To first
// order this equals T * Exp_SE3(delta); we use the decoupled form because it is what the
// GICP Jacobians are derived with, and its inverse is exact.
#include "mapdelta/common/pose.hpp"
#include "mapdelta/common/registration/gicp.hpp"

namespace mapdelta {

// T (+) delta.
SE3 RetractRight(const SE3& T, const Vector6d& delta);
// The delta with RetractRight(T_ref, delta) == T (exact inverse of RetractRight).
Vector6d LocalRight(const SE3& T_ref, const SE3& T);

}  // namespace mapdelta
