// MapService: a tile's observed octree (GET /v1/observed/tiles/{t}.bt), merged from its
// sessions' octrees and kept per tile state in the ObservedTileCache.
#include <cstdio>
#include <optional>
#include <set>

#include "blob_codec.hpp"
#include "mapdelta/common/number_text.hpp"
#include "mapdelta/common/observed_area.hpp"
#include "mapdelta/server/map_service.hpp"
#include "observed_crop.hpp"
#include "observed_tile_cache.hpp"
#include "query_params.hpp"

namespace mapdelta::server {
namespace {

// Everything the bytes depend on: the tile, its stored state (the session set, and the time of
// the write that made it, which every commit's ApplyUpdates sets), the octree resolution and the
// tile size. Two processes on one database derive the same key, so the same ETag.
std::string ObservedKey(const TileStateRecord& state, const ServerConfig& config) {
  std::string key = state.tile.ToString() + "|" + std::to_string(state.updated_ms) + "|" +
                    ShortestNumber(config.pipeline.octree_resolution_m) + "|" +
                    ShortestNumber(config.storage.tile_size_m) + "|";
  for (int64_t s : state.sessions) key += std::to_string(s) + ",";
  return key;
}

// FNV-1a (64 bit) of the key, quoted: a short strong validator for If-None-Match.
std::string ETagOf(const std::string& key) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : key) h = (h ^ c) * 1099511628211ull;
  char etag[32];
  std::snprintf(etag, sizeof etag, "\"obs-%016llx\"", static_cast<unsigned long long>(h));
  return etag;
}

// The sessions' octrees merged in id order, as ObservedCache::Merged merges them (so the same
// bytes), but one decoded session at a time: the job's cache keeps every session it decoded for
// the job's tiles; a request has no use for them after its merge, and with 80 sessions holding
// them all made each request's peak memory ~80 octrees instead of ~2.
std::string MergedOctree(Storage& storage, const std::set<int64_t>& sessions, double resolution_m) {
  auto decode = [&storage](int64_t s) -> std::optional<ObservedArea> {
    const auto blob = storage.sessions().GetObserved(s);
    if (!blob) return std::nullopt;
    return ObservedArea::DeserializeBinary(DecodeObserved(*blob));
  };
  if (sessions.size() == 1) {  // nothing to merge: the session's own octree
    if (auto area = decode(*sessions.begin())) return area->SerializeBinary();
  }
  ObservedArea merged(resolution_m);
  for (int64_t s : sessions) {
    if (auto area = decode(s)) merged.Merge(*area);
  }
  return merged.SerializeBinary();
}

}  // namespace

FilePayload MapService::GetObservedTile(const std::string& tile_text,
                                        const std::function<bool(const std::string&)>& client_has) {
  const TileId tile = ParseTile(tile_text);
  // Read on every request (one row), so a commit by any process is seen at once.
  auto state = storage_->tiles().GetState(tile);
  if (!state || state->sessions.empty())
    throw ApiError(ApiCode::kNotFound, "tile " + tile_text + " has no observations");
  const std::string key = ObservedKey(*state, config_);
  FilePayload p;
  p.etag = ETagOf(key);
  p.content_type = "application/octet-stream";
  p.prior_version = storage_->priors().LatestVersion().value_or(0);
  if (client_has && client_has(p.etag)) return p;  // 304: no merge, no bytes
  const std::shared_ptr<const std::string> bt = observed_cache_->Get(key, [&] {
    // The merged octree covers the sessions' whole drives: cut it to this tile.
    const AxisAlignedBox b = TileGrid(config_.storage.tile_size_m).Bounds(tile);
    return CropOctreeXY(
        MergedOctree(*storage_, state->sessions, config_.pipeline.octree_resolution_m), b.min.x(),
        b.min.y(), b.max.x(), b.max.y());
  });
  p.bytes.assign(bt->begin(), bt->end());
  return p;
}

ObservedCacheStats MapService::ObservedCacheStatistics() const { return observed_cache_->Stats(); }

}  // namespace mapdelta::server
