// Changed scenes (S1, S2) and the mirror variant. Both changed scenes are derived from one
// deterministic plan, so S1 and S2 never pick the same building or lot.
#include <algorithm>
#include <cmath>
#include <limits>

#include "mapdelta/common/error.hpp"
#include "mapdelta/sim/random.hpp"
#include "mapdelta/sim/scene.hpp"

namespace mapdelta::sim {
namespace {

double Dist2D(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return (a - b).head<2>().norm();
}

struct ChangePlan {
  size_t lot[2];
  int removed_id[2];
};

ChangePlan Plan(const Scene& s, uint64_t seed) {
  if (s.empty_lots.size() < 2)
    throw Error(ErrorCode::kInvalidArgument, "scene has fewer than 2 empty lots");
  Rng rng(HashCombine(seed, 0xc4a9e));
  ChangePlan p{};
  // Prefer lots near the centre: trajectories of the short presets start there.
  std::vector<size_t> order(s.empty_lots.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return s.empty_lots[a].area.Center().head<2>().norm() <
           s.empty_lots[b].area.Center().head<2>().norm();
  });
  const size_t pool = std::min<size_t>(order.size(), 4);
  p.lot[0] = order[rng.Int(0, static_cast<int>(pool) - 1)];
  do {
    p.lot[1] = order[rng.Int(0, static_cast<int>(pool) - 1)];
  } while (p.lot[1] == p.lot[0]);
  for (int k = 0; k < 2; ++k) {
    // Remove the building closest to the new lot, so one short flight sees both changes.
    double best = std::numeric_limits<double>::infinity();
    p.removed_id[k] = -1;
    const Eigen::Vector3d c = s.empty_lots[p.lot[k]].area.Center();
    for (const Object& o : s.objects) {
      if (o.kind != "building" || (k == 1 && o.id == p.removed_id[0])) continue;
      const double d = Dist2D(o.Bounds().Center(), c);
      if (d < best) {
        best = d;
        p.removed_id[k] = o.id;
      }
    }
    if (p.removed_id[k] < 0)
      throw Error(ErrorCode::kInvalidArgument, "scene has too few buildings");
  }
  return p;
}

}  // namespace

ChangedScene MakeChangedScene(const Scene& original, int which, uint64_t seed) {
  if (which != 1 && which != 2)
    throw Error(ErrorCode::kInvalidArgument, "changed scene must be 1 or 2");
  const ChangePlan plan = Plan(original, seed);
  const int k = which - 1;
  ChangedScene out;
  out.scene = original;
  out.scene.name = "S" + std::to_string(which);
  // 1. Remove the planned building.
  auto& objs = out.scene.objects;
  auto it = std::find_if(objs.begin(), objs.end(),
                         [&](const Object& o) { return o.id == plan.removed_id[k]; });
  out.changes.push_back({"removed", *it});
  objs.erase(it);
  // 2. Add a building on the planned lot: a plain box, tall enough to be seen from 15 m up.
  const Lot lot = original.empty_lots[plan.lot[k]];
  Rng rng(HashCombine(seed, 0xadd0 + which));
  Object added;
  added.id = original.next_id + which;  // distinct ids for S1's and S2's new buildings
  added.kind = "building";
  const Box& a = lot.area;
  const double inset = std::min(2.0, 0.12 * std::min(a.max.x() - a.min.x(), a.max.y() - a.min.y()));
  Box b;
  b.min = {a.min.x() + inset, a.min.y() + inset, 0.0};
  b.max = {a.max.x() - inset, a.max.y() - inset, rng.Uniform(14.0, 22.0)};
  added.boxes.push_back(b);
  added.material = which == 1 ? Material::kBrick : Material::kPlaster;
  added.albedo = static_cast<float>(rng.Uniform(0.45, 0.7));
  added.texture_seed = static_cast<uint32_t>(rng.Next());
  out.scene.objects.push_back(added);
  out.scene.empty_lots.erase(out.scene.empty_lots.begin() + static_cast<long>(plan.lot[k]));
  out.scene.next_id = original.next_id + 3;
  out.changes.push_back({"added", added});
  return out;
}

std::vector<Object> MakeMirrors(Scene* scene, const Box& removed,
                                const Eigen::Vector2d& route_point) {
  std::vector<Object> mirrors;
  Object ground;
  ground.kind = "mirror";
  ground.material = Material::kMirror;
  ground.albedo = 0.9f;
  Box g = removed;
  g.min += Eigen::Vector3d(1.0, 1.0, 0.0);
  g.max = Eigen::Vector3d(removed.max.x() - 1.0, removed.max.y() - 1.0, 0.03);
  g.min.z() = 0.0;
  ground.boxes.push_back(g);
  mirrors.push_back(ground);

  // The facade closest to the route point, on the side that faces it.
  double best = std::numeric_limits<double>::infinity();
  Box wall;
  int axis = 0;
  double sign = 1;
  for (const Object& o : scene->objects) {
    if (o.kind != "building") continue;
    for (const Box& b : o.boxes) {
      const double dx = std::max({b.min.x() - route_point.x(), 0.0, route_point.x() - b.max.x()});
      const double dy = std::max({b.min.y() - route_point.y(), 0.0, route_point.y() - b.max.y()});
      const double d = std::hypot(dx, dy);
      if (d < best && b.max.z() >= 7.0) {
        best = d;
        wall = b;
        axis = dx >= dy ? 0 : 1;
        sign = axis == 0 ? (route_point.x() > b.max.x() ? 1 : -1)
                         : (route_point.y() > b.max.y() ? 1 : -1);
      }
    }
  }
  if (std::isfinite(best)) {
    Object m = ground;
    Box mb;
    const int other = 1 - axis;
    const double c = 0.5 * (wall.min[other] + wall.max[other]);
    const double half = std::min(3.0, 0.5 * (wall.max[other] - wall.min[other]) - 0.5);
    const double face = sign > 0 ? wall.max[axis] : wall.min[axis];
    mb.min[axis] = sign > 0 ? face : face - 0.06;
    mb.max[axis] = sign > 0 ? face + 0.06 : face;
    mb.min[other] = c - half;
    mb.max[other] = c + half;
    mb.min.z() = 1.0;
    mb.max.z() = 6.5;
    m.boxes = {mb};
    mirrors.push_back(m);
  }
  for (Object& m : mirrors) {
    m.id = scene->next_id++;
    scene->objects.push_back(m);
  }
  return mirrors;
}

}  // namespace mapdelta::sim
