#pragma once
// Internal: the OcTree behind ObservedArea, shared by observed_area.cpp and observed_area_io.cpp.
#include <octomap/OcTree.h>

#include <string>
#include <string_view>

#include "flat_key_set.hpp"
#include "mapdelta/common/observed_area.hpp"

namespace mapdelta {

struct ObservedArea::Impl {
  explicit Impl(double resolution_m) : tree(resolution_m) {}
  octomap::OcTree tree;
};

struct PriorSurfaces::Impl {
  Impl(double resolution_m, size_t expected) : grid(resolution_m), voxels(expected) {}
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
