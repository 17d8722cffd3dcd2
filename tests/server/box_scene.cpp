#include "box_scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mapdelta::testing {

double Box::Distance(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d d = (min - p).cwiseMax(p - max).cwiseMax(Eigen::Vector3d::Zero());
  return d.norm();
}

namespace {
// Slab test: entry distance t of the ray o + t d into the box, or +inf.
double HitBox(const Box& b, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  double t0 = 0, t1 = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) {
    if (std::abs(d[i]) < 1e-12) {
      if (o[i] < b.min[i] || o[i] > b.max[i]) return std::numeric_limits<double>::infinity();
      continue;
    }
    double a = (b.min[i] - o[i]) / d[i], c = (b.max[i] - o[i]) / d[i];
    if (a > c) std::swap(a, c);
    t0 = std::max(t0, a);
    t1 = std::min(t1, c);
    if (t0 > t1) return std::numeric_limits<double>::infinity();
  }
  return t0 > 1e-9 ? t0 : std::numeric_limits<double>::infinity();
}
}  // namespace

DepthImage BoxScene::Render(const PinholeCamera& camera, const SE3& T_map_cam,
                            double max_depth_m) const {
  DepthImage depth(camera.width, camera.height);
  const Eigen::Vector3d o = T_map_cam.translation();
  const Eigen::Matrix3d R = T_map_cam.rotation();
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      // Direction with unit optical-axis component, so the hit parameter t is the depth z.
      const Eigen::Vector3d d =
          R * Eigen::Vector3d((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);
      double t = std::numeric_limits<double>::infinity();
      if (d.z() < -1e-12) {
        const double tg = (ground_z - o.z()) / d.z();
        const Eigen::Vector3d g = o + tg * d;
        if (g.x() >= ground.min.x() && g.x() < ground.max.x() && g.y() >= ground.min.y() &&
            g.y() < ground.max.y())
          t = tg;
      }
      for (const Box& b : boxes) t = std::min(t, HitBox(b, o, d));
      if (t < max_depth_m) depth.at(u, v) = static_cast<float>(t);
    }
  }
  return depth;
}

PointCloud BoxScene::Sample(double s) const {
  PointCloud cloud;
  auto inside_box = [&](const Eigen::Vector3d& p) {
    for (const Box& b : boxes) {
      if ((p.array() > b.min.array() + 1e-6).all() && (p.array() < b.max.array() - 1e-6).all())
        return true;
    }
    return false;
  };
  for (double x = ground.min.x(); x < ground.max.x(); x += s) {
    for (double y = ground.min.y(); y < ground.max.y(); y += s) {
      bool covered = false;
      for (const Box& b : boxes)
        covered |= x > b.min.x() && x < b.max.x() && y > b.min.y() && y < b.max.y() &&
                   b.min.z() <= ground_z;
      if (!covered) cloud.emplace_back(float(x), float(y), float(ground_z));
    }
  }
  for (const Box& b : boxes) {
    const Eigen::Vector3d e = b.max - b.min;
    // Four sides and the top, each on its own grid.
    for (double a = 0; a <= e.x() + 1e-9; a += s) {
      for (double c = 0; c <= e.z() + 1e-9; c += s) {
        for (double y : {b.min.y(), b.max.y()}) {
          const Eigen::Vector3d p(b.min.x() + a, y, b.min.z() + c);
          if (!inside_box(p)) cloud.push_back(p.cast<float>());
        }
      }
    }
    for (double a = 0; a <= e.y() + 1e-9; a += s) {
      for (double c = 0; c <= e.z() + 1e-9; c += s) {
        for (double x : {b.min.x(), b.max.x()}) {
          const Eigen::Vector3d p(x, b.min.y() + a, b.min.z() + c);
          if (!inside_box(p)) cloud.push_back(p.cast<float>());
        }
      }
    }
    for (double a = s; a < e.x(); a += s) {
      for (double c = s; c < e.y(); c += s)
        cloud.emplace_back(float(b.min.x() + a), float(b.min.y() + c), float(b.max.z()));
    }
  }
  return cloud;
}

SE3 CameraLookingMinusY(double x, double y, double height, double pitch_rad) {
  Eigen::Matrix3d R;
  // Columns: camera x (right) = -x_map, camera y (down) = -z_map, camera z (forward) = -y_map.
  R << -1, 0, 0,  //
      0, 0, -1,   //
      0, -1, 0;
  SE3 T = SE3::Identity();
  // Pitch about the camera's x axis, turning the optical axis towards camera +y (down).
  T.linear() = R * Eigen::AngleAxisd(-pitch_rad, Eigen::Vector3d::UnitX()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, height);
  return T;
}

}  // namespace mapdelta::testing
