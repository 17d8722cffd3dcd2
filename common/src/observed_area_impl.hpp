#pragma once
// Internal: the OcTree behind ObservedArea, shared by observed_area.cpp and observed_area_io.cpp.
#include <octomap/OcTree.h>

#include <string>
#include <string_view>

#include "flat_key_set.hpp"
#include "mapdelta/common/observed_area.hpp"

namespace mapdelta {

// Every OcTree allocates a ray buffer of 100000 keys (600 KB) for OctoMap's own insertRay /
// castRay / computeUpdate, which nothing here calls (rays are cast by AddRayKeys into a KeyRay
// of its own; merges and queries need none): the trees drop it. A commit job holds every decoded
// session octree of its tiles, so with 80 sessions this buffer was 48 of its 118 MB heap peak
// (heaptrack, docs/reliability.md). Those OctoMap calls would throw std::out_of_range on such a
// tree, not misbehave.
struct ObservedArea::Impl {
  explicit Impl(double resolution_m) : tree(resolution_m) { tree.clearKeyRays(); }
  Impl(const Impl& other) : tree(other.tree) { tree.clearKeyRays(); }
  octomap::OcTree tree;
};

struct PriorSurfaces::Impl {
  Impl(double resolution_m, size_t expected) : grid(resolution_m), voxels(expected) {
    grid.clearKeyRays();
  }
  octomap::OcTree grid;       // empty: only its key arithmetic (the observed area's keys)
  detail::FlatKeySet voxels;  // packed keys of the voxels holding prior points
};

namespace detail {
struct OctomapStream {
  double resolution_m = 0;
  size_t data_offset = 0;  // where the node data starts, after the header's 'data' line
  bool full = false;       // .ot (log-odds per node) rather than .bt
  bool empty = false;      // size 0: no node data
};
// Checks an OctoMap binary (.bt) or full (.ot) stream completely: header lines, resolution, and
// that the node data is well formed, no deeper than 16 levels, has exactly `size` nodes and ends
// where the bytes end (.ot: every log-odds finite). Throws Error(kParse) prefixed with `what`.
OctomapStream ValidateOctomapStream(std::string_view bytes, const std::string& what);
}  // namespace detail

}  // namespace mapdelta
