#pragma once
// Coverage and freshness (issue #20 item 4): per (tile, session) the session touched (its
// commit aggregated it), which of the tile's prior points the session observed (its observed
// octree knows their voxels). A tile without prior points keeps its rows, with no bits: when
// a later version gives it points, they are computed from the same sessions. A row indexes the
// points of one prior tile row (prior_row_version = PriorTileRecord::version, the version that
// wrote the tile's points), so a row whose tile was rewritten since is stale: the jobs that
// write prior versions bring the rows up to date (coverage.hpp), and readers ignore a row
// whose prior_row_version is not the tile's current one. The session's vehicle and created
// time are kept in the row, so a window of days needs no join.
#include <cstdint>
#include <string>
#include <vector>

#include "mapdelta/common/tiling.hpp"
#include "mapdelta/server/storage_types.hpp"

namespace mapdelta::server {

struct CoverageRecord {
  TileId tile;
  int64_t session_id = 0;
  std::string vehicle_id;
  int64_t observed_ms = 0;        // the session's created time
  int64_t prior_row_version = 0;  // the prior tile row whose points the bits index (0: none)
  int64_t prior_points = 0;       // points of that row (= bits in the set)
  int64_t observed_points = 0;    // bits set
  Bytes bits;                     // opaque here (service-encoded); empty in listings without bits
};

class CoverageStore {
 public:
  virtual ~CoverageStore() = default;
  // One transaction: each record inserts or replaces the row of its (tile, session_id).
  virtual void Put(const std::vector<CoverageRecord>& records) = 0;
  // Rows of tiles in the rect with observed_ms >= since_ms, ordered by (ix, iy, session_id);
  // bits filled in only if with_bits.
  virtual std::vector<CoverageRecord> List(const Rect& rect, int64_t since_ms, bool with_bits) = 0;
};

}  // namespace mapdelta::server
