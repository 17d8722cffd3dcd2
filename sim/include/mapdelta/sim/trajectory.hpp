#pragma once
// Smooth MAV trajectories: a route along the street grid, turned into a uniform cubic B-spline
// in time (C2: continuous acceleration). The body keeps level and heads along its velocity, so
// all derivatives (velocity, acceleration, yaw rate) are analytic.
#include <Eigen/Core>
#include <vector>

#include "mapdelta/common/pose.hpp"
#include "mapdelta/sim/scene.hpp"

namespace mapdelta::sim {

struct MotionState {
  Eigen::Vector3d p_map = Eigen::Vector3d::Zero();  // body position
  Eigen::Vector3d v_map = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_map = Eigen::Vector3d::Zero();
  double yaw = 0, yaw_rate = 0;
  SE3 T_map_body = SE3::Identity();
  Eigen::Vector3d omega_body = Eigen::Vector3d::Zero();  // gyro reading without noise
  Eigen::Vector3d f_body = Eigen::Vector3d::Zero();      // specific force: R^T (a - g)
};

constexpr double kGravity = 9.81;  // m/s^2 along -z of the map

class SplineTrajectory {
 public:
  // control points in the map frame; knot_dt seconds between control points (>= 4 points).
  SplineTrajectory(std::vector<Eigen::Vector3d> control, double knot_dt);
  double duration() const;  // valid time range is [0, duration()]
  MotionState Evaluate(double t) const;
  const std::vector<Eigen::Vector3d>& control() const { return control_; }

 private:
  std::vector<Eigen::Vector3d> control_;
  double dt_;
};

// A route through the street grid (a polyline of intersections at flight height) that
// passes along the streets beside `targets` (x/y points, visited in order), extended by a
// random walk without U-turns to at least `length_m`.
std::vector<Eigen::Vector2d> PlanRoute(const StreetGrid& streets,
                                       const std::vector<Eigen::Vector2d>& targets, double length_m,
                                       uint64_t seed);

// Samples the polyline every `spacing` metres, adds a gentle height wave (amplitude grows with
// height), and sets knot spacing for `speed` m/s.
SplineTrajectory MakeTrajectory(const std::vector<Eigen::Vector2d>& route, double height,
                                double spacing, double speed);

}  // namespace mapdelta::sim
