#include "synthetic_scene.hpp"

#include <array>
#include <vector>

namespace mapdelta::test {
namespace {

struct Box {
  Eigen::Vector3d min, max;
};

// Buildings of various sizes and orientations-free (axis-aligned) placement, plus thin poles,
// chosen so that all six degrees of freedom are constrained (walls facing x and y, ground,
// roofs at several heights).
const std::array<Box, 7> kBoxes = {{
    {{-15, -12, 0}, {-6, -4, 8}},
    {{4, -14, 0}, {12, -9, 5}},
    {{6, 3, 0}, {14, 14, 11}},
    {{-14, 6, 0}, {-9, 15, 4}},
    {{-2, -2, 0}, {-1.6, -1.6, 6}},
    {{2, 6, 0}, {2.4, 6.4, 5}},
    {{-4, 10, 0}, {0, 12, 2.5}},
}};
constexpr double kHalfExtent = 20.0;

double BoxArea(const Box& b) {
  const Eigen::Vector3d d = b.max - b.min;
  return 2 * (d.x() * d.z() + d.y() * d.z()) + d.x() * d.y();  // walls and roof, no floor
}

Eigen::Vector3d SampleOnBox(const Box& b, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  const Eigen::Vector3d d = b.max - b.min;
  const std::array<double, 5> areas = {d.x() * d.z(), d.x() * d.z(), d.y() * d.z(), d.y() * d.z(),
                                       d.x() * d.y()};
  double pick = u(rng) * (areas[0] + areas[1] + areas[2] + areas[3] + areas[4]);
  int face = 0;
  while (face < 4 && pick > areas[face]) pick -= areas[face++];
  Eigen::Vector3d p(b.min.x() + u(rng) * d.x(), b.min.y() + u(rng) * d.y(),
                    b.min.z() + u(rng) * d.z());
  switch (face) {
    case 0:
      p.y() = b.min.y();
      break;
    case 1:
      p.y() = b.max.y();
      break;
    case 2:
      p.x() = b.min.x();
      break;
    case 3:
      p.x() = b.max.x();
      break;
    default:
      p.z() = b.max.z();
      break;
  }
  return p;
}

bool InsideAnyBox(double x, double y) {
  for (const auto& b : kBoxes) {
    if (x > b.min.x() && x < b.max.x() && y > b.min.y() && y < b.max.y()) return true;
  }
  return false;
}

}  // namespace

PointCloud SampleUrbanScene(size_t num_points, double noise_m, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> noise(0, noise_m);
  const double ground_area = 4 * kHalfExtent * kHalfExtent;
  std::vector<double> areas = {ground_area};
  for (const auto& b : kBoxes) areas.push_back(BoxArea(b));
  std::discrete_distribution<size_t> pick_surface(areas.begin(), areas.end());
  PointCloud cloud;
  cloud.reserve(num_points);
  while (cloud.size() < num_points) {
    const size_t s = pick_surface(rng);
    Eigen::Vector3d p;
    if (s == 0) {
      p = Eigen::Vector3d((2 * u(rng) - 1) * kHalfExtent, (2 * u(rng) - 1) * kHalfExtent, 0);
      if (InsideAnyBox(p.x(), p.y())) continue;
    } else {
      p = SampleOnBox(kBoxes[s - 1], rng);
    }
    const Eigen::Vector3d n(noise(rng), noise(rng), noise(rng));
    cloud.push_back((p + n).cast<float>());
  }
  return cloud;
}

}  // namespace mapdelta::test
