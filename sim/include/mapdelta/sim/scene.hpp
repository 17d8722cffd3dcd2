#pragma once
// The procedural city: a street grid, buildings made of axis-aligned boxes, small objects and
// (for the mirror variant) mirrors. Everything stands on the ground plane z = 0 of the map frame.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "mapdelta/sim/config.hpp"

namespace mapdelta::sim {

struct Box {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
  Eigen::Vector3d Center() const { return 0.5 * (min + max); }
  bool ContainsStrict(const Eigen::Vector3d& p, double eps) const {
    return (p.array() > min.array() + eps).all() && (p.array() < max.array() - eps).all();
  }
};

// Surface appearance; textures are procedural (texture.hpp).
enum class Material : uint8_t {
  kBrick,
  kPlaster,
  kConcrete,
  kCar,
  kTrunk,
  kFoliage,
  kMetal,
  kMirror
};

struct Object {
  int id = 0;        // stable across original/S1/S2 (added buildings get new ids)
  std::string kind;  // "building", "car", "tree", "lamp", "kiosk", "mirror"
  Material material = Material::kBrick;
  float albedo = 0.5f;        // base brightness in [0, 1]
  uint32_t texture_seed = 0;  // varies bricks, windows, colours per object
  std::vector<Box> boxes;     // union of boxes; overlapping boxes are allowed
  Box Bounds() const;
};

struct Lighting {
  Eigen::Vector3d sun_dir = Eigen::Vector3d(0.4, 0.3, 0.85).normalized();  // towards the sun
  double sun = 0.75;                                                       // direct light scale
  double ambient = 0.35;                                                   // sky light scale
  double exposure = 1.0;                                                   // camera gain
};

// A street segment between two neighbouring grid intersections.
struct StreetGrid {
  std::vector<double> xs;  // x of streets running along y
  std::vector<double> ys;  // y of streets running along x
  double width = 12.0;     // full width; sidewalks are the outer 2.5 m on each side
  double sidewalk = 2.5;
  Eigen::Vector2d Node(int i, int j) const { return {xs[i], ys[j]}; }
};

// An empty lot where a changed scene may put a new building.
struct Lot {
  Box area;                        // z range 0..0
  int block_i = -1, block_j = -1;  // block between streets i,i+1 and j,j+1 (-1: unknown)
};

struct Scene {
  std::string name = "original";
  double extent_x = 0, extent_y = 0;
  StreetGrid streets;
  std::vector<Object> objects;
  std::vector<Lot> empty_lots;
  Lighting lighting;
  int next_id = 0;

  const Object* Find(int id) const;
};

struct Change {
  std::string type;  // "removed" or "added"
  Object object;
};

struct ChangedScene {
  Scene scene;
  std::vector<Change> changes;
};

// Generates the original city from config (extent, blocks, heights, small objects) and seed.
Scene GenerateCity(const SimConfig& config, uint64_t seed);
// S1 / S2: removes one building next to a street and adds one on an empty lot nearby.
// `which` is 1 or 2; the two changed scenes use different buildings and lots.
ChangedScene MakeChangedScene(const Scene& original, int which, uint64_t seed);
// The mirror variant: one mirror on a facade visible from `route_point` and one on the ground
// where the removed building stood.
std::vector<Object> MakeMirrors(Scene* scene, const Box& removed_footprint,
                                const Eigen::Vector2d& route_point);
// The low-sun variant's lighting.
Lighting DarkLighting();

}  // namespace mapdelta::sim
