#include "box_scene.hpp"

#include <cmath>
#include <cstdint>
#include <limits>

namespace mapdelta::testing {

PointCloud SampleBoxSurfaces(const std::vector<Box>& boxes, double spacing) {
  PointCloud cloud;
  for (const Box& box : boxes) {
    const Eigen::Vector3d size = box.max - box.min;
    for (int axis = 0; axis < 3; ++axis) {  // the two faces normal to `axis`
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      const int na = static_cast<int>(std::floor(size[a] / spacing)) + 1;
      const int nb = static_cast<int>(std::floor(size[b] / spacing)) + 1;
      for (const double face : {box.min[axis], box.max[axis]}) {
        for (int i = 0; i < na; ++i) {
          for (int j = 0; j < nb; ++j) {
            Eigen::Vector3d p;
            p[axis] = face;
            p[a] = box.min[a] + i * spacing;
            p[b] = box.min[b] + j * spacing;
            cloud.push_back(p.cast<float>());
          }
        }
      }
    }
  }
  return cloud;
}

namespace {

// Slab test: smallest t > 0 with origin + t * dir inside the box, or +inf.
double Intersect(const Box& box, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) {
  double t_near = -std::numeric_limits<double>::infinity();
  double t_far = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    if (std::abs(dir[k]) < 1e-12) {
      if (origin[k] < box.min[k] || origin[k] > box.max[k])
        return std::numeric_limits<double>::infinity();
      continue;
    }
    double t0 = (box.min[k] - origin[k]) / dir[k];
    double t1 = (box.max[k] - origin[k]) / dir[k];
    if (t0 > t1) std::swap(t0, t1);
    t_near = std::max(t_near, t0);
    t_far = std::min(t_far, t1);
  }
  if (t_near > t_far || t_far <= 0) return std::numeric_limits<double>::infinity();
  return t_near > 0 ? t_near : std::numeric_limits<double>::infinity();
}

}  // namespace

DepthImage RenderDepth(const PinholeCamera& camera, const SE3& T_map_cam,
                       const std::vector<Box>& boxes) {
  DepthImage depth(camera.width, camera.height);
  const Eigen::Vector3d origin = T_map_cam.translation();
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      // Direction with unit z in the camera frame, so the ray parameter is the depth.
      const Eigen::Vector3d dir = T_map_cam.linear() * camera.BackProject(u, v, 1.0);
      double best = std::numeric_limits<double>::infinity();
      for (const Box& box : boxes) best = std::min(best, Intersect(box, origin, dir));
      depth.at(u, v) = std::isfinite(best) ? static_cast<float>(best) : 0.f;
    }
  }
  return depth;
}

SE3 LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  SE3 T = SE3::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = y;
  T.linear().col(2) = z;
  T.translation() = eye;
  return T;
}

BoxWorld MakeBoxWorld() {
  const Box ground{{-40, -40, -1}, {40, 40, 0}};
  const Box a{{-19, -19, 0}, {-11, -11, 10}}, b{{11, -19, 0}, {19, -11, 12}};
  const Box c{{-18, 10, 0}, {-12, 20, 8}}, d{{11, 11, 0}, {19, 19, 10}};
  BoxWorld world;
  world.original = {ground, a, b, c};
  world.changed = {ground, a, c, d};
  PinholeCamera camera;
  camera.width = 200;
  camera.height = 150;
  camera.fx = camera.fy = 125;
  camera.cx = 100;
  camera.cy = 75;
  world.keyframes.camera = camera;
  for (int k = 0; k < 24; ++k) {
    const double angle = 2 * M_PI * k / 24;
    Keyframe keyframe;
    keyframe.t_ns = 1'000'000'000LL * (k + 1);
    keyframe.T_map_cam = LookAt({30 * std::cos(angle), 30 * std::sin(angle), 25}, {0, 0, 0});
    keyframe.depth = RenderDepth(camera, keyframe.T_map_cam, world.changed);
    world.keyframes.keyframes.push_back(keyframe);
  }
  return world;
}

}  // namespace mapdelta::testing
