#pragma once
// The versioned, tiled prior map. A tile's points at version V are its row with the greatest
// version <= V, so a version only writes the tiles it changed and every old version stays
// readable.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "mapdelta/common/tiling.hpp"
#include "mapdelta/server/map_frame.hpp"
#include "mapdelta/server/states.hpp"
#include "mapdelta/server/storage_types.hpp"

namespace mapdelta::server {

struct PriorVersionRecord {
  int64_t version = 0;
  int64_t created_ms = 0;
  PriorSource source = PriorSource::kImport;
  std::string note;
  std::optional<int64_t> parent, job_id;
  // CreateVersion only: the frame this version's points are local to. The first version that
  // carries one sets the map's frame (Frame()); later ones must carry the same (SameFrame).
  // Versions without one (refresh) stay in the stored frame.
  std::optional<MapFrame> frame;
};

struct PriorTileRecord {
  TileId tile;
  int64_t version = 0;  // the version that wrote this row (<= the version asked for)
  int64_t point_count = 0;
  Bytes points;  // empty in listings
};

class PriorStore {
 public:
  virtual ~PriorStore() = default;
  // Creates version latest + 1 (parent = latest) with these tiles, atomically. If replace_all,
  // tiles with points at the previous version that are absent here get an empty row (no
  // points) so they read as empty at the new version. Throws Error(kConflict), writing
  // nothing, if a tile appears twice, or if meta.frame differs from the stored frame.
  virtual int64_t CreateVersion(const PriorVersionRecord& meta,
                                const std::vector<PriorTileRecord>& tiles, bool replace_all) = 0;
  virtual std::optional<int64_t> LatestVersion() = 0;
  // The map's frame, or nullopt until a version carrying one was created (maps from before
  // frames existed: their points are in unnamed coordinates at origin 0).
  virtual std::optional<MapFrame> Frame() = 0;
  virtual std::vector<PriorVersionRecord> ListVersions() = 0;  // by version
  // The tile's row at that version (possibly an empty row), or nullopt if it never had one.
  virtual std::optional<PriorTileRecord> GetTile(const TileId& tile, int64_t version) = 0;
  // Tiles (without points) in the rect at a version, non-empty only, ordered by (ix, iy).
  virtual std::vector<PriorTileRecord> ListTiles(const Rect& rect, int64_t version) = 0;
};

}  // namespace mapdelta::server
