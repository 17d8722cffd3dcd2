#pragma once
// Ray casting against a Scene: the ground plane z = 0 plus every object's boxes.
// EmbreeCaster uses Intel Embree's BVH; BruteForceCaster tests every box (the oracle for tests
// and the baseline for bench/bench_sim). Both return the same Hit for the same ray.
#include <Eigen/Core>
#include <memory>

#include "mapdelta/sim/scene.hpp"

namespace mapdelta::sim {

struct Hit {
  float t = 0.f;  // distance along the (not necessarily unit) direction
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();  // outward face normal
  int object = -1;                                    // index into Scene::objects; -1 = ground
  int box = -1;                                       // index into that object's boxes
};

// Far side of the ground plane: it spans the scene plus this margin, so the horizon is ground.
constexpr double kGroundMargin = 400.0;

class RayCaster {
 public:
  virtual ~RayCaster() = default;
  // Closest hit with t in (tnear, tfar); false if none.
  virtual bool Intersect(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, float tnear,
                         float tfar, Hit* hit) const = 0;
  // True if anything is hit with t in (tnear, tfar).
  virtual bool Occluded(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, float tnear,
                        float tfar) const = 0;
};

class EmbreeCaster final : public RayCaster {
 public:
  explicit EmbreeCaster(const Scene& scene);  // throws Error(kInternal) if Embree fails
  ~EmbreeCaster() override;
  EmbreeCaster(const EmbreeCaster&) = delete;
  EmbreeCaster& operator=(const EmbreeCaster&) = delete;
  bool Intersect(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, float tnear, float tfar,
                 Hit* hit) const override;
  bool Occluded(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, float tnear,
                float tfar) const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class BruteForceCaster final : public RayCaster {
 public:
  explicit BruteForceCaster(const Scene& scene);
  bool Intersect(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, float tnear, float tfar,
                 Hit* hit) const override;
  bool Occluded(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, float tnear,
                float tfar) const override;

 private:
  struct Entry {
    Eigen::Vector3f min, max;
    int object, box;
  };
  std::vector<Entry> boxes_;
  Eigen::Vector2f ground_min_, ground_max_;
};

}  // namespace mapdelta::sim
