#include "mapdelta/sim/sensor_rig.hpp"

#include <cmath>

#include "mapdelta/common/error.hpp"
#include "mapdelta/sim/dataset_writer.hpp"

namespace mapdelta::sim {

Eigen::Vector2d RadTan::Distort(const Eigen::Vector2d& p) const {
  const double x = p.x(), y = p.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + k1 * r2 + k2 * r2 * r2;
  return {x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
          y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y};
}

bool RadTan::Undistort(const Eigen::Vector2d& xd, Eigen::Vector2d* out) const {
  // Newton on Distort(x) = xd with the analytic 2x2 Jacobian, started at x = xd. A fixed
  // iteration count (OpenCV's undistortPoints uses 5 fixed-point steps) leaves pixel-size errors
  // in the corners of a k1 = -0.28 lens; Newton reaches machine precision in a few steps.
  Eigen::Vector2d x = xd;
  for (int it = 0; it < 50; ++it) {
    const double u = x.x(), v = x.y();
    const double r2 = u * u + v * v;
    const double radial = 1.0 + k1 * r2 + k2 * r2 * r2;
    const double dradial = k1 + 2.0 * k2 * r2;  // d radial / d r2
    Eigen::Matrix2d J;
    J(0, 0) = radial + 2.0 * u * u * dradial + 2.0 * p1 * v + 6.0 * p2 * u;
    J(0, 1) = 2.0 * u * v * dradial + 2.0 * p1 * u + 2.0 * p2 * v;
    J(1, 0) = 2.0 * u * v * dradial + 2.0 * p1 * u + 2.0 * p2 * v;
    J(1, 1) = radial + 2.0 * v * v * dradial + 6.0 * p1 * v + 2.0 * p2 * u;
    const Eigen::Vector2d r = Distort(x) - xd;
    if (r.norm() < 1e-13) {
      *out = x;
      return true;
    }
    if (std::abs(J.determinant()) < 1e-9) return false;  // fold of the lens model
    x -= J.inverse() * r;
    if (!x.allFinite() || x.norm() > 10.0) return false;
  }
  *out = x;
  return (Distort(x) - xd).norm() < 1e-10;
}

SensorRig MakeSensorRig(const SimConfig& c) {
  if (c.rig == "euroc") return EurocMh01Rig();
  if (c.rig != "ideal") {
    throw Error(ErrorCode::kInvalidArgument,
                "unknown rig '" + c.rig + "' (expected ideal or euroc)");
  }
  SensorRig rig;
  rig.name = "ideal";
  PinholeCamera K;
  K.width = c.width;
  K.height = c.height;
  K.fx = c.fx;
  K.fy = c.fy;
  K.cx = c.cx;
  K.cy = c.cy;
  rig.cam[0].K = rig.cam[1].K = K;
  rig.cam[0].T_body_cam = BodyToCam0();
  SE3 T_cam0_cam1 = SE3::Identity();
  T_cam0_cam1.translation() = Eigen::Vector3d(c.baseline, 0, 0);
  rig.cam[1].T_body_cam = rig.cam[0].T_body_cam * T_cam0_cam1;
  return rig;
}

SensorRig EurocMh01Rig() {
  // EuRoC MAV dataset, MH_01_easy mav0/cam0|cam1/sensor.yaml (VI-Sensor, MT9M034 cameras).
  SensorRig rig;
  rig.name = "euroc";
  auto camera = [](double fx, double fy, double cx, double cy, RadTan d, const double(&T)[12]) {
    SimCamera cam;
    cam.K.width = 752;
    cam.K.height = 480;
    cam.K.fx = fx;
    cam.K.fy = fy;
    cam.K.cx = cx;
    cam.K.cy = cy;
    cam.distortion = d;
    Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
    for (int r = 0; r < 3; ++r) {
      for (int k = 0; k < 4; ++k) M(r, k) = T[4 * r + k];
    }
    cam.T_body_cam.matrix() = M;  // verbatim: written back to sensor.yaml as published
    return cam;
  };
  const double T0[12] = {0.0148655429818,  -0.999880929698,  0.00414029679422, -0.0216401454975,
                         0.999557249008,   0.0149672133247,  0.025715529948,   -0.064676986768,
                         -0.0257744366974, 0.00375618835797, 0.999660727178,   0.00981073058949};
  const double T1[12] = {0.0125552670891,  -0.999755099723, 0.0182237714554, -0.0198435579556,
                         0.999598781151,   0.0130119051815, 0.0251588363115, 0.0453689425024,
                         -0.0253898008918, 0.0179005838253, 0.999517347078,  0.00786212447038};
  rig.cam[0] = camera(458.654, 457.296, 367.215, 248.375,
                      {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05}, T0);
  rig.cam[1] = camera(457.587, 456.134, 379.999, 255.238,
                      {-0.28368365, 0.07451284, -0.00010473, -3.55590700e-05}, T1);
  // EuRoC's IMU axes: x up, y right, z forward (its cameras look along IMU z with image x along
  // IMU y). In the vehicle's FLU axes: body x = up, body y = -left, body z = forward.
  rig.T_vehicle_body.linear() << 0, 0, 1, 0, -1, 0, 1, 0, 0;
  return rig;
}

std::vector<Eigen::Vector3f> PixelRays(const SimCamera& cam) {
  const PinholeCamera& K = cam.K;
  std::vector<Eigen::Vector3f> rays(static_cast<size_t>(K.width) * K.height);
  for (int v = 0; v < K.height; ++v) {
    for (int u = 0; u < K.width; ++u) {
      const Eigen::Vector2d xd((u - K.cx) / K.fx, (v - K.cy) / K.fy);
      Eigen::Vector2d x;
      Eigen::Vector3f& ray = rays[static_cast<size_t>(v) * K.width + u];
      if (cam.distortion.IsZero()) {
        ray = Eigen::Vector3f(static_cast<float>(xd.x()), static_cast<float>(xd.y()), 1.f);
      } else if (cam.distortion.Undistort(xd, &x)) {
        ray = Eigen::Vector3f(static_cast<float>(x.x()), static_cast<float>(x.y()), 1.f);
      } else {
        ray.setZero();
      }
    }
  }
  return rays;
}

}  // namespace mapdelta::sim
