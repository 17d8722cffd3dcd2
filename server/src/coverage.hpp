#pragma once
// Coverage and freshness (issue #20 item 4; coverage_store.hpp): which prior points of a tile
// each session observed, written by the commit job and brought up to date by the jobs that
// write prior versions; the per-tile summary the coverage routes answer with.
#include <nlohmann/json.hpp>

#include <optional>
#include <set>
#include <string>
#include <vector>

#include "mapdelta/common/observed_area.hpp"
#include "mapdelta/server/storage.hpp"
#include "point_bits.hpp"

namespace mapdelta::server {

// Bit i set = the i-th point of the prior tile row (DecodePoints order) lies in a voxel the
// area knows (ObservedArea::IsObserved, as the classifier's A_obs).
PointBits ObservedBits(const ObservedArea& area, const PointCloud& prior_points);

// The session's coverage rows of these tiles (the tiles its commit touched) at prior_version;
// a tile without prior points gets a row without bits.
std::vector<CoverageRecord> SessionCoverage(Storage& storage, const SessionRecord& session,
                                            const ObservedArea& area,
                                            const std::vector<TileId>& tiles,
                                            int64_t prior_version);

struct CoverageRecomputed {
  int64_t rows = 0;      // rows rewritten because their tile's points changed
  int64_t tiles = 0;     // tiles they were in
  int64_t sessions = 0;  // distinct sessions whose octree was read
};

// After a prior version was written: every row whose tile reads from another prior row at the
// latest version is recomputed from its session's stored octree (no bits set if the session
// has none); repeated while the latest version moves meanwhile. Idempotent (a resumed job runs
// it again).
CoverageRecomputed RecomputeCoverage(Storage& storage);

// The commit's rows: SessionCoverage of these tiles at the latest version, written, and again
// if a version was written meanwhile (whose own recomputation may have missed them). Returns
// the tiles with an observed point.
int64_t WriteSessionCoverage(Storage& storage, const SessionRecord& session,
                             const ObservedArea& area, const std::vector<TileId>& tiles);
// {"rows", "tiles", "sessions"} for a job's result.
nlohmann::json CoverageJson(const CoverageRecomputed& r);

struct TileCoverage {
  TileId tile;
  int64_t prior_points = 0, observed_points = 0;
  std::optional<int64_t> last_observed_ms;  // the newest session observing a point, any age
  std::set<int64_t> sessions;               // observing a point within the window
  std::set<std::string> vehicles;           // their vehicles
  double fraction() const {
    return prior_points > 0 ? static_cast<double>(observed_points) / prior_points : 0.0;
  }
};

// One tile's summary: `prior` its current prior row, `all` its rows of any age (bits not
// needed), `window` its rows observed since the window's start, with bits. Rows without an
// observed point, and rows of another prior row (not yet recomputed), are ignored.
TileCoverage SummarizeTile(const PriorTileRecord& prior, const std::vector<CoverageRecord>& all,
                           const std::vector<CoverageRecord>& window);

}  // namespace mapdelta::server
