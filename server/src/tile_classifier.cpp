#include "tile_classifier.hpp"

#include <algorithm>
#include <cmath>

#include "mapdelta/common/change_detection.hpp"
#include "mapdelta/common/neighbor_index.hpp"

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
};

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
      if (auto state = storage.tiles().GetState(t))
        n.aggregates.push_back(DecodeAggregate(state->aggregate));
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

// Sessions that have aggregated points within radius of p.
std::set<int64_t> SessionsNear(const Neighbourhood& n, const NeighborIndex& index, const Point& p,
                               float radius) {
  std::set<int64_t> out;
  for (size_t i : index.RadiusSearch(p, radius)) {
    out.insert(n.voxels[i]->sessions.begin(), n.voxels[i]->sessions.end());
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

}  // namespace

TileClassification ClassifyTile(Storage& storage, const TileGrid& grid, const TileId& tile,
                                int64_t prior_version, const ClassifyConfig& params,
                                const ChangeDetectionParams& detection, ObservedCache& cache) {
  TileClassification out;
  out.record.tile = tile;
  out.record.prior_version = prior_version;
  out.record.params_json = "{\"th_ch_m\":" + std::to_string(params.th_ch_m) +
                           ",\"min_voxel_support\":" + std::to_string(params.min_voxel_support) +
                           "}";
  std::set<int64_t> tile_sessions;
  if (auto state = storage.tiles().GetState(tile)) tile_sessions = state->sessions;

  if (!tile_sessions.empty()) {
    const Neighbourhood n = LoadNeighbourhood(storage, grid, tile, prior_version, params);
    const ObservedArea& observed = cache.Merged(tile_sessions, detection.observed.resolution_m);
    const double th_ch = params.th_ch_m;
    // Step 2: paper Alg. 1 (observed prior) and Alg. 2 (new / removed) on the neighbourhood.
    const PointCloud observed_prior =
        ObservedPriorCloud(n.prior, n.global, observed, th_ch, detection.threads);
    const Changes changes = ClassifyChanges(n.global, observed_prior, th_ch, detection.threads);

    // Step 3: evidence and confidence for the points inside the tile.
    const AxisAlignedBox bounds = grid.Bounds(tile);
    const NeighborIndex global_index(n.global);
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
      std::set<int64_t> near(c.supported_by.begin(), c.supported_by.end());
      c.observed_by = ObservingSessions(tile_sessions, cache, p, near);
      c.confidence = Confidence(c.supported_by.size(), c.observed_by.size());
      out.changes.push_back(std::move(c));
    }
    const int min_free = detection.removed_min_free_keyframes;
    for (const Point& p : changes.removed_points) {
      if (!bounds.Contains(p)) continue;
      if (min_free > 0 && !observed.IsSeenFree(p, min_free)) continue;
      const std::set<int64_t> near = SessionsNear(n, global_index, p, radius);
      ChangePoint c;
      c.position = p;
      c.kind = ChangeKind::kRemoved;
      c.observed_by = ObservingSessions(tile_sessions, cache, p, near);
      for (int64_t s : c.observed_by) {
        if (!near.count(s)) c.supported_by.push_back(s);
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
