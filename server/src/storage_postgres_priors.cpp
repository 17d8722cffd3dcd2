// PostgreSQL prior store: versioned prior tiles.
#include <set>

#include "storage_postgres.hpp"

namespace mapdelta::server {
namespace {

std::optional<MapFrame> ReadFrame(pg::Connection& c) {
  const pg::Result r =
      c.Query("SELECT crs, origin_x, origin_y, origin_z FROM map_frame WHERE id = 1");
  if (r.rows() == 0) return std::nullopt;
  return MapFrame{r.Text(0, 0), Eigen::Vector3d(r.Real(0, 1), r.Real(0, 2), r.Real(0, 3))};
}

// Called under the prior-version lock (LockPriorVersions), so two first imports cannot both
// store a frame; a different frame is a conflict and the caller's transaction rolls back.
void CheckOrStoreFrame(pg::Connection& c, const MapFrame& frame) {
  if (const auto stored = ReadFrame(c)) return RequireSameFrame(*stored, frame);
  c.Query("INSERT INTO map_frame (id, crs, origin_x, origin_y, origin_z) VALUES (1,$1,$2,$3,$4)",
          pg::Params()
              .Add(frame.crs)
              .Add(frame.origin.x())
              .Add(frame.origin.y())
              .Add(frame.origin.z()));
}

}  // namespace

int64_t PostgresPriorStore::CreateVersion(const PriorVersionRecord& meta,
                                          const std::vector<PriorTileRecord>& tiles,
                                          bool replace_all) {
  auto c = Connect();
  pg::Transaction tx(*c);
  const int64_t previous = pg_rows::LockPriorVersions(*c);
  if (meta.frame) CheckOrStoreFrame(*c, *meta.frame);
  const int64_t version = previous + 1;
  c->Query(
      "INSERT INTO prior_versions (version, created_ms, source, parent, note, "
      "job_id) "
      "VALUES ($1,$2,$3,$4,$5,$6)",
      pg::Params()
          .Add(version)
          .Add(meta.created_ms)
          .Add(ToString(meta.source))
          .Add(previous > 0 ? std::optional<int64_t>(previous) : std::nullopt)
          .Add(meta.note)
          .Add(meta.job_id));
  std::set<std::string> written;
  for (const PriorTileRecord& t : tiles) {
    pg_rows::InsertPriorTile(*c, version, t.tile.ToString(), t.tile.ix(), t.tile.iy(),
                             t.point_count, t.points);
    written.insert(t.tile.ToString());
  }
  if (replace_all && previous > 0) {
    // Tiles that had points before but are absent now must read as empty at this version.
    const pg::Result r = c->Query(
        "SELECT tile, ix, iy FROM prior_tiles p "
        "WHERE version = (SELECT MAX(version) "
        "FROM prior_tiles q WHERE q.tile = p.tile "
        "AND q.version <= $1) AND point_count > 0",
        pg::Params().Add(previous));
    for (int i = 0; i < r.rows(); ++i) {
      if (written.count(r.Text(i, 0))) continue;
      pg_rows::InsertPriorTile(*c, version, r.Text(i, 0), r.Int(i, 1), r.Int(i, 2), 0, Bytes{});
    }
  }
  tx.Commit();
  return version;
}

std::optional<int64_t> PostgresPriorStore::LatestVersion() {
  auto c = Connect();
  return c->Query("SELECT MAX(version) FROM prior_versions").OptInt(0, 0);
}

std::optional<MapFrame> PostgresPriorStore::Frame() {
  auto c = Connect();
  return ReadFrame(*c);
}

std::vector<PriorVersionRecord> PostgresPriorStore::ListVersions() {
  auto c = Connect();
  const pg::Result r = c->Query(
      "SELECT version, created_ms, source, parent, "
      "note, job_id FROM prior_versions "
      "ORDER BY version");
  std::vector<PriorVersionRecord> out;
  for (int i = 0; i < r.rows(); ++i) {
    PriorVersionRecord v;
    v.version = r.Int(i, 0);
    v.created_ms = r.Int(i, 1);
    v.source = ParseEnumOrThrow<PriorSource>(r.Text(i, 2), "prior_versions.source");
    v.parent = r.OptInt(i, 3);
    v.note = r.Text(i, 4);
    v.job_id = r.OptInt(i, 5);
    out.push_back(v);
  }
  return out;
}

std::optional<PriorTileRecord> PostgresPriorStore::GetTile(const TileId& tile, int64_t version) {
  auto c = Connect();
  const pg::Result r = c->Query(
      "SELECT version, point_count, points FROM "
      "prior_tiles WHERE tile = $1 AND version <= $2 "
      "ORDER BY version DESC LIMIT 1",
      pg::Params().Add(tile.ToString()).Add(version));
  if (r.rows() == 0) return std::nullopt;
  PriorTileRecord t;
  t.tile = tile;
  t.version = r.Int(0, 0);
  t.point_count = r.Int(0, 1);
  t.points = r.Bytes(0, 2);
  return t;
}

std::vector<PriorTileRecord> PostgresPriorStore::ListTiles(const Rect& rect, int64_t version) {
  auto c = Connect();
  // rect is in tile indices here (the service converts metres to tile ranges).
  pg::Params p;
  pg_rows::AddTileRange(p, rect).Add(version);
  const pg::Result r = c->Query(
      "SELECT ix, iy, version, point_count FROM prior_tiles p "
      "WHERE ix BETWEEN $1 AND $2 AND iy BETWEEN $3 AND $4 AND "
      "version = (SELECT MAX(version) "
      "FROM prior_tiles q WHERE q.tile = p.tile AND q.version <= $5) "
      "AND point_count > 0 "
      "ORDER BY ix, iy",
      p);
  std::vector<PriorTileRecord> out;
  for (int i = 0; i < r.rows(); ++i) {
    PriorTileRecord t;
    t.tile = TileId(static_cast<int32_t>(r.Int(i, 0)), static_cast<int32_t>(r.Int(i, 1)));
    t.version = r.Int(i, 2);
    t.point_count = r.Int(i, 3);
    out.push_back(t);
  }
  return out;
}

}  // namespace mapdelta::server
