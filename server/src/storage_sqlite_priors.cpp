// SQLite prior store: versioned prior tiles.
#include <set>
#include <tuple>

#include "storage_sqlite.hpp"

namespace mapdelta::server {
namespace {

std::optional<MapFrame> ReadFrame(sql::Db& db) {
  sql::Stmt s(db, "SELECT crs, origin_x, origin_y, origin_z FROM map_frame WHERE id = 1");
  if (!s.Step()) return std::nullopt;
  return MapFrame{s.Text(0), Eigen::Vector3d(s.Real(1), s.Real(2), s.Real(3))};
}

// The first version with a frame stores it; a different one is a conflict (nothing written:
// the caller's transaction rolls back).
void CheckOrStoreFrame(sql::Db& db, const MapFrame& frame) {
  if (const auto stored = ReadFrame(db)) return RequireSameFrame(*stored, frame);
  sql::Stmt s(db,
              "INSERT INTO map_frame (id, crs, origin_x, origin_y, origin_z) VALUES (1,?,?,?,?)");
  s.Bind(1, frame.crs)
      .Bind(2, frame.origin.x())
      .Bind(3, frame.origin.y())
      .Bind(4, frame.origin.z());
  s.Run();
}

}  // namespace

int64_t SqlitePriorStore::CreateVersion(const PriorVersionRecord& meta,
                                        const std::vector<PriorTileRecord>& tiles,
                                        bool replace_all) {
  auto lock = Lock();
  sql::Transaction tx(db());
  if (meta.frame) CheckOrStoreFrame(db(), *meta.frame);
  int64_t previous = 0;
  {
    sql::Stmt s(db(), "SELECT COALESCE(MAX(version), 0) FROM prior_versions");
    if (s.Step()) previous = s.Int(0);
  }
  const int64_t version = previous + 1;
  {
    sql::Stmt s(db(),
                "INSERT INTO prior_versions (version, created_ms, source, parent, note, job_id) "
                "VALUES (?,?,?,?,?,?)");
    s.Bind(1, version).Bind(2, meta.created_ms).Bind(3, ToString(meta.source));
    if (previous > 0)
      s.Bind(4, previous);
    else
      s.BindNull(4);
    s.Bind(5, meta.note);
    if (meta.job_id)
      s.Bind(6, *meta.job_id);
    else
      s.BindNull(6);
    s.Run();
  }
  sql::Stmt ins(db(),
                "INSERT INTO prior_tiles (version, tile, ix, iy, point_count, points) "
                "VALUES (?,?,?,?,?,?)");
  std::set<std::string> written;
  for (const PriorTileRecord& t : tiles) {
    ins.Reset();
    ins.Bind(1, version)
        .Bind(2, t.tile.ToString())
        .Bind(3, int64_t{t.tile.ix()})
        .Bind(4, int64_t{t.tile.iy()})
        .Bind(5, t.point_count)
        .Bind(6, t.points);
    ins.Run();
    written.insert(t.tile.ToString());
  }
  if (replace_all && previous > 0) {
    // Tiles that had points before but are absent now must read as empty at this version.
    sql::Stmt s(db(),
                "SELECT tile, ix, iy FROM prior_tiles p WHERE version = (SELECT MAX(version) "
                "FROM prior_tiles q WHERE q.tile = p.tile AND q.version <= ?) AND point_count > 0");
    s.Bind(1, previous);
    std::vector<std::tuple<std::string, int64_t, int64_t>> gone;
    while (s.Step()) {
      if (!written.count(s.Text(0))) gone.emplace_back(s.Text(0), s.Int(1), s.Int(2));
    }
    for (const auto& [tile, ix, iy] : gone) {
      ins.Reset();
      ins.Bind(1, version)
          .Bind(2, tile)
          .Bind(3, ix)
          .Bind(4, iy)
          .Bind(5, int64_t{0})
          .Bind(6, Bytes{});
      ins.Run();
    }
  }
  tx.Commit();
  return version;
}

std::optional<int64_t> SqlitePriorStore::LatestVersion() {
  auto lock = Lock();
  sql::Stmt s(db(), "SELECT MAX(version) FROM prior_versions");
  if (!s.Step() || s.IsNull(0)) return std::nullopt;
  return s.Int(0);
}

std::optional<MapFrame> SqlitePriorStore::Frame() {
  auto lock = Lock();
  return ReadFrame(db());
}

std::vector<PriorVersionRecord> SqlitePriorStore::ListVersions() {
  auto lock = Lock();
  sql::Stmt s(db(),
              "SELECT version, created_ms, source, parent, note, job_id FROM prior_versions "
              "ORDER BY version");
  std::vector<PriorVersionRecord> out;
  while (s.Step()) {
    PriorVersionRecord r;
    r.version = s.Int(0);
    r.created_ms = s.Int(1);
    r.source = ParseEnumOrThrow<PriorSource>(s.Text(2), "prior_versions.source");
    if (!s.IsNull(3)) r.parent = s.Int(3);
    r.note = s.Text(4);
    if (!s.IsNull(5)) r.job_id = s.Int(5);
    out.push_back(r);
  }
  return out;
}

std::optional<PriorTileRecord> SqlitePriorStore::GetTile(const TileId& tile, int64_t version) {
  auto lock = Lock();
  sql::Stmt s(
      db(),
      "SELECT version, point_count, points FROM prior_tiles WHERE tile = ? AND version <= ? "
      "ORDER BY version DESC LIMIT 1");
  s.Bind(1, tile.ToString()).Bind(2, version);
  if (!s.Step()) return std::nullopt;
  PriorTileRecord r;
  r.tile = tile;
  r.version = s.Int(0);
  r.point_count = s.Int(1);
  r.points = s.Blob(2);
  return r;
}

std::vector<PriorTileRecord> SqlitePriorStore::ListTiles(const Rect& rect, int64_t version) {
  auto lock = Lock();
  // rect is in tile indices here (the service converts metres to tile ranges).
  sql::Stmt s(db(),
              "SELECT tile, ix, iy, version, point_count FROM prior_tiles p "
              "WHERE ix BETWEEN ? AND ? AND iy BETWEEN ? AND ? AND version = (SELECT MAX(version) "
              "FROM prior_tiles q WHERE q.tile = p.tile AND q.version <= ?) AND point_count > 0 "
              "ORDER BY ix, iy");
  s.Bind(1, static_cast<int64_t>(rect.min_x))
      .Bind(2, static_cast<int64_t>(rect.max_x))
      .Bind(3, static_cast<int64_t>(rect.min_y))
      .Bind(4, static_cast<int64_t>(rect.max_y))
      .Bind(5, version);
  std::vector<PriorTileRecord> out;
  while (s.Step()) {
    PriorTileRecord r;
    r.tile = TileId(static_cast<int32_t>(s.Int(1)), static_cast<int32_t>(s.Int(2)));
    r.version = s.Int(3);
    r.point_count = s.Int(4);
    out.push_back(r);
  }
  return out;
}

}  // namespace mapdelta::server
