#include "tile_classifier.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "mapdelta/common/change_detection.hpp"
#include "mapdelta/common/neighbor_index.hpp"
#include "mapdelta/common/parallel.hpp"
#include "voxel_consensus.hpp"

namespace mapdelta::server {

void ObservedCache::Put(int64_t session_id, ObservedArea area) {
  std::lock_guard lock(mutex_);
  sessions_[session_id] = std::make_unique<ObservedArea>(std::move(area));
}

const ObservedArea* ObservedCache::Session(int64_t session_id) {
  std::lock_guard lock(mutex_);
  return SessionLocked(session_id);
}

const ObservedArea* ObservedCache::SessionLocked(int64_t session_id) {
  auto it = sessions_.find(session_id);
  if (it == sessions_.end()) {
    std::unique_ptr<ObservedArea> area;
    if (auto blob = storage_.sessions().GetObserved(session_id)) {
      area = std::make_unique<ObservedArea>(ObservedArea::DeserializeBinary(DecodeObserved(*blob)));
    }
    it = sessions_.emplace(session_id, std::move(area)).first;
  }
  return it->second.get();
}

const ObservedArea& ObservedCache::Merged(const std::set<int64_t>& sessions, double resolution_m) {
  // Held while merging: a second tile with the same sessions waits for this merge, not redoes it.
  std::lock_guard lock(mutex_);
  auto it = merged_.find(sessions);
  if (it != merged_.end()) return *it->second;
  if (sessions.size() == 1) {  // nothing to merge: the session's own octree (no copy)
    if (const ObservedArea* area = SessionLocked(*sessions.begin())) return *area;
  }
  auto merged = std::make_unique<ObservedArea>(resolution_m);
  for (int64_t s : sessions) {
    if (const ObservedArea* area = SessionLocked(s)) merged->Merge(*area);
  }
  return *merged_.emplace(sessions, std::move(merged)).first->second;
}

namespace {

struct Neighbourhood {
  PointCloud prior;
  PointCloud global;                          // aggregated voxel centroids with enough support
  std::vector<const AggregateVoxel*> voxels;  // parallel to global
  std::vector<TileAggregate> aggregates;      // owns the voxels
  std::set<int64_t> sessions;                 // of the nine tiles
};

// The octrees of `sessions` (those that have one), looked up once: the per-point loops below
// then read them without the cache's lock.
std::vector<std::pair<int64_t, const ObservedArea*>> AreasOf(const std::set<int64_t>& sessions,
                                                             ObservedCache& cache) {
  std::vector<std::pair<int64_t, const ObservedArea*>> out;
  for (int64_t s : sessions) {
    if (const ObservedArea* area = cache.Session(s)) out.emplace_back(s, area);
  }
  return out;
}

// Voxel consensus (voxel_consensus.hpp): the neighbourhood's voxels that other sessions were at
// without reproducing them are left out of the global cloud.
void DropUnreproducedVoxels(Neighbourhood& n, ObservedCache& cache, double reach_m, int threads) {
  std::map<int64_t, const ObservedArea*> areas;
  for (const auto& [s, area] : AreasOf(n.sessions, cache)) areas.emplace(s, area);
  const std::vector<char> keep = VoxelsWithConsensus(
      n.voxels, n.global, std::vector<int64_t>(n.sessions.begin(), n.sessions.end()),
      [&](int64_t s, const Point& p) {
        const auto it = areas.find(s);
        return it != areas.end() && it->second->IsObserved(p);
      },
      reach_m, threads);
  PointCloud global;
  std::vector<const AggregateVoxel*> voxels;
  for (size_t i = 0; i < n.global.size(); ++i) {
    if (!keep[i]) continue;
    global.push_back(n.global[i]);
    voxels.push_back(n.voxels[i]);
  }
  n.global = std::move(global);
  n.voxels = std::move(voxels);
}

// Step 1: prior points and aggregated voxels of the tile and its 8 neighbours, cropped to the
// tile grown by th_ch (points farther away cannot change any decision inside the tile).
Neighbourhood LoadNeighbourhood(Storage& storage, const TileGrid& grid, const TileId& tile,
                                int64_t prior_version, const ClassifyConfig& params) {
  Neighbourhood n;
  AxisAlignedBox box = grid.Bounds(tile);
  const float margin = static_cast<float>(params.th_ch_m);
  box.min.head<2>().array() -= margin;
  box.max.head<2>().array() += margin;
  n.aggregates.reserve(9);
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      const TileId t(tile.ix() + dx, tile.iy() + dy);
      if (auto prior = storage.priors().GetTile(t, prior_version)) {
        for (const Point& p : DecodePoints(prior->points)) {
          if (box.Contains(p)) n.prior.push_back(p);
        }
      }
      if (auto state = storage.tiles().GetState(t)) {
        n.aggregates.push_back(DecodeAggregate(state->aggregate));
        n.sessions.insert(state->sessions.begin(), state->sessions.end());
      }
    }
  }
  for (const TileAggregate& agg : n.aggregates) {
    for (const auto& [key, voxel] : agg) {
      if (static_cast<int>(voxel.sessions.size()) < params.min_voxel_support) continue;
      if (!box.Contains(voxel.centroid)) continue;
      n.global.push_back(voxel.centroid);
      n.voxels.push_back(&voxel);
    }
  }
  return n;
}

float Confidence(size_t supported, size_t observed) {
  return static_cast<float>(supported + 1) / static_cast<float>(observed + 2);
}

// The sessions that filled a voxel within radius of p; `index` is built on the centroids of
// `voxels`, in the same order.
std::set<int64_t> SessionsNear(const std::vector<const AggregateVoxel*>& voxels,
                               const NeighborIndex& index, const Point& p, float radius) {
  std::set<int64_t> out;
  for (size_t i : index.RadiusSearch(p, radius)) {
    out.insert(voxels[i]->sessions.begin(), voxels[i]->sessions.end());
  }
  return out;
}

// Under a mask radius (ChangeDetectionParams::removed_mask_radius_m), the voxels that may mask a
// removal (Alg. 2: those within th_ch of it) and their centroids: those that re-observe a prior
// surface or lie outside the prior's footprint, and that some session saw in mask_min_keyframes
// keyframes or that lie within mask_weak_radius_m of the prior (MaskingPoints; voxels aggregated
// before the count was kept have keyframes 0 and mask as before).
struct MaskingVoxels {
  std::vector<const AggregateVoxel*> voxels;
  PointCloud centroids;
};

MaskingVoxels MaskingVoxelsOf(const Neighbourhood& n, const ChangeDetectionParams& detection) {
  std::vector<uint32_t> keyframes(n.voxels.size());
  for (size_t i = 0; i < n.voxels.size(); ++i) keyframes[i] = n.voxels[i]->keyframes;
  const MaskingSupport support{&keyframes, detection.mask_min_keyframes,
                               detection.mask_weak_radius_m};
  MaskingVoxels out;
  for (size_t i : MaskingPoints(n.global, n.prior, detection.removed_mask_radius_m,
                                detection.new_footprint_radius_m, detection.threads, support)) {
    out.voxels.push_back(n.voxels[i]);
    out.centroids.push_back(n.global[i]);
  }
  return out;
}

std::vector<int64_t> ObservingSessions(const std::set<int64_t>& tile_sessions, ObservedCache& cache,
                                       const Point& p, const std::set<int64_t>& near) {
  std::vector<int64_t> out;
  for (int64_t s : tile_sessions) {
    const ObservedArea* area = cache.Session(s);
    if (near.count(s) || (area && area->IsObserved(p))) out.push_back(s);
  }
  return out;
}

// A removed point's evidence under the confident free-space rule, session by session: a session
// supports it when its own octree sees the point's voxel free with min_free keyframes net of
// hits; it contradicts it when it has aggregated points within th_ch (of those that may mask it,
// MaskingVoxels) or its octree holds the voxel as not free at all (a surface seen there); a
// session that only grazed the voxel (free, with less evidence) observed too little to say and
// is left out of both. Summing stray rays of many sessions in one merged octree (the rule
// before) let every upload add false removals.
void RemovedEvidence(const std::vector<std::pair<int64_t, const ObservedArea*>>& areas,
                     const Point& p, int min_free, const std::set<int64_t>& near, ChangePoint* c) {
  for (const auto& [s, area] : areas) {
    const bool has_points_near = near.count(s) > 0;
    if (!has_points_near && area->IsSeenFree(p, min_free)) {
      c->supported_by.push_back(s);
      c->observed_by.push_back(s);
    } else if (has_points_near || (area->IsObserved(p) && !area->IsSeenFree(p, 1))) {
      c->observed_by.push_back(s);
    }
  }
  for (int64_t s : near) {  // near sessions without an octree still observed the place
    if (std::find(c->observed_by.begin(), c->observed_by.end(), s) == c->observed_by.end())
      c->observed_by.push_back(s);
  }
  std::sort(c->observed_by.begin(), c->observed_by.end());
}

// NotSeenFree (change_detection.hpp) session by session: a new point stays when at least one
// session that filled its voxel does not hold that voxel free in its own octree (its rays ended
// there at least as often as they passed). A merged octree would let earlier sessions, which
// drove through before the new object stood there, outvote it.
bool SomeSessionEndedRaysAt(const std::vector<int64_t>& sessions, ObservedCache& cache,
                            const Point& p) {
  for (int64_t s : sessions) {
    const ObservedArea* area = cache.Session(s);
    if (!area || !area->IsSeenFree(p, 1)) return true;
  }
  return false;
}

}  // namespace

TileClassification ClassifyTile(Storage& storage, const TileGrid& grid, const TileId& tile,
                                int64_t prior_version, const ClassifyConfig& params,
                                const ChangeDetectionParams& detection, ObservedCache& cache) {
  TileClassification out;
  out.record.tile = tile;
  out.record.prior_version = prior_version;
  out.record.params_json = "{\"th_ch_m\":" + std::to_string(params.th_ch_m) +
                           ",\"min_voxel_support\":" + std::to_string(params.min_voxel_support) +
                           ",\"voxel_consensus\":" + (params.voxel_consensus ? "true" : "false") +
                           ",\"consensus_reach_m\":" + std::to_string(params.consensus_reach_m) +
                           "}";
  std::set<int64_t> tile_sessions;
  if (auto state = storage.tiles().GetState(tile)) tile_sessions = state->sessions;

  const int min_free = detection.removed_min_free_keyframes;
  if (!tile_sessions.empty()) {
    Neighbourhood n = LoadNeighbourhood(storage, grid, tile, prior_version, params);
    if (params.voxel_consensus && min_free > 0)
      DropUnreproducedVoxels(n, cache, params.consensus_reach_m, detection.threads);
    const ObservedArea& observed = cache.Merged(tile_sessions, detection.observed.resolution_m);
    const double th_ch = params.th_ch_m;
    // Step 2: paper Alg. 1 (observed prior) and Alg. 2 (new / removed) on the neighbourhood.
    const PointCloud observed_prior =
        ObservedPriorCloud(n.prior, n.global, observed, th_ch, detection.threads);
    const bool masked = min_free > 0 && detection.removed_mask_radius_m > 0;
    const MaskingVoxels masking = masked ? MaskingVoxelsOf(n, detection) : MaskingVoxels{};
    Changes changes = ClassifyChanges(n.global, observed_prior, th_ch, detection.threads,
                                      masked ? &masking.centroids : nullptr);
    changes.new_points = WithinPriorFootprint(changes.new_points, n.prior,
                                              detection.new_footprint_radius_m, detection.threads);

    // Step 3: evidence and confidence for the points inside the tile.
    const AxisAlignedBox bounds = grid.Bounds(tile);
    const NeighborIndex global_index(n.global);
    // A removed point's sessions near it are those of the voxels that may mask it.
    std::optional<NeighborIndex> masking_index;
    if (masked) masking_index.emplace(masking.centroids);
    const NeighborIndex& near_index = masked ? *masking_index : global_index;
    const std::vector<const AggregateVoxel*>& near_voxels = masked ? masking.voxels : n.voxels;
    const float radius = static_cast<float>(th_ch);
    for (const Point& p : changes.new_points) {
      if (!bounds.Contains(p)) continue;
      size_t i = 0;
      float d = 0;
      if (!global_index.Nearest(p, &i, &d)) continue;
      ChangePoint c;
      c.position = p;
      c.kind = ChangeKind::kNew;
      c.supported_by = n.voxels[i]->sessions;
      if (detection.new_not_seen_free && !SomeSessionEndedRaysAt(c.supported_by, cache, p))
        continue;
      std::set<int64_t> near(c.supported_by.begin(), c.supported_by.end());
      c.observed_by = ObservingSessions(tile_sessions, cache, p, near);
      c.confidence = Confidence(c.supported_by.size(), c.observed_by.size());
      out.changes.push_back(std::move(c));
    }
    const auto tile_areas = AreasOf(tile_sessions, cache);
    for (const Point& p : changes.removed_points) {
      if (!bounds.Contains(p)) continue;
      const std::set<int64_t> near = SessionsNear(near_voxels, near_index, p, radius);
      ChangePoint c;
      c.position = p;
      c.kind = ChangeKind::kRemoved;
      if (min_free > 0) {
        RemovedEvidence(tile_areas, p, min_free, near, &c);
        if (c.supported_by.empty()) continue;  // no session saw the place free on its own
      } else {  // the paper's rule: every observing session without points near supports it
        c.observed_by = ObservingSessions(tile_sessions, cache, p, near);
        for (int64_t s : c.observed_by) {
          if (!near.count(s)) c.supported_by.push_back(s);
        }
      }
      c.confidence = Confidence(c.supported_by.size(), c.observed_by.size());
      out.changes.push_back(std::move(c));
    }
  }
  for (const ChangePoint& c : out.changes) {
    (c.kind == ChangeKind::kNew ? out.record.new_count : out.record.removed_count) += 1;
    out.record.max_confidence = std::max(out.record.max_confidence, double{c.confidence});
  }
  out.record.changes = EncodeChanges(out.changes);
  return out;
}

}  // namespace mapdelta::server
