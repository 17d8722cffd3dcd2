#pragma once
// Classifies one tile from its aggregate (paper Alg. 1 + 2 via common/change_detection) and
// attaches evidence and a confidence to every new/removed point.
//
// Confidence of a change point = (S + 1) / (O + 2), where O = sessions that observed the
// place (their observed octree covers it, or they have aggregated points within th_ch) and
// S = sessions whose own data agree with the change (for a new point: sessions that put a
// point in its voxel; for a removed point: observing sessions without any point within th_ch).
// It is Laplace's rule of succession: the posterior mean of "a vehicle passing here sees this
// change" under a uniform prior, treating each observing session as one trial. One session
// gives 0.67, two agreeing 0.75, four agreeing 0.83; one of two agreeing 0.5.
//
// Under the confident free-space rule (pipeline.free_space, removed_min_free_keyframes > 0) the
// evidence is weighed session by session, since sessions are what the lifecycle counts:
// - a removed point needs one session that saw its voxel free on its own (min_free keyframes net
//   of that session's hits); S = those sessions, O = S plus the sessions that saw a surface
//   there (points within th_ch, or the voxel not free at all in their octree). A session that
//   only grazed the voxel is neither. Before, stray rays of many sessions were summed in one
//   merged octree, so every upload added false removals (docs/results.md, crowd run).
// - with classify.voxel_consensus, an aggregated voxel that k sessions filled is left out of the
//   global cloud when k other sessions were there without filling it (voxel_consensus.hpp: one
//   session's noise, a misplaced session or a passing object).
#include <map>
#include <memory>
#include <mutex>
#include <set>

#include "blob_codec.hpp"
#include "mapdelta/common/change_detection.hpp"
#include "mapdelta/common/observed_area.hpp"
#include "mapdelta/common/tiling.hpp"
#include "mapdelta/server/config.hpp"
#include "mapdelta/server/storage.hpp"

namespace mapdelta::server {

// Per-job cache of decoded session octrees and of merges over session sets. Thread-safe (jobs
// classify tiles in parallel); returned references stay valid for the cache's lifetime.
class ObservedCache {
 public:
  explicit ObservedCache(Storage& storage) : storage_(storage) {}
  const ObservedArea* Session(int64_t session_id);  // nullptr if the session has none
  const ObservedArea& Merged(const std::set<int64_t>& sessions, double resolution_m);
  // Seeds the cache with an octree the job already has (saves decoding the stored copy).
  void Put(int64_t session_id, ObservedArea area);

 private:
  const ObservedArea* SessionLocked(int64_t session_id);

  std::recursive_mutex mutex_;
  Storage& storage_;
  std::map<int64_t, std::unique_ptr<ObservedArea>> sessions_;
  std::map<std::set<int64_t>, std::unique_ptr<ObservedArea>> merged_;
};

struct TileClassification {
  std::vector<ChangePoint> changes;
  TileChangesRecord record;  // counts, max confidence, encoded changes
};

// Loads the tile's and its neighbours' prior (at prior_version) and aggregates, classifies
// the points inside the tile and returns the record to store. From `detection`: the octree
// resolution, and the free-space rule's per-point evidence (a removed point's voxel seen free
// by removed_min_free_keyframes keyframes of one session, see above).
TileClassification ClassifyTile(Storage& storage, const TileGrid& grid, const TileId& tile,
                                int64_t prior_version, const ClassifyConfig& params,
                                const ChangeDetectionParams& detection, ObservedCache& cache);

}  // namespace mapdelta::server
