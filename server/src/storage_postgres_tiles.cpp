// PostgreSQL tile store: per-tile aggregation, classification, refresh, settings.
#include "storage_postgres.hpp"

namespace mapdelta::server {

const char* const pg_rows::kUpsertTileChanges =
    "ON CONFLICT (tile) DO UPDATE SET ix = EXCLUDED.ix, iy = EXCLUDED.iy, "
    "prior_version = EXCLUDED.prior_version, new_count = EXCLUDED.new_count, "
    "removed_count = EXCLUDED.removed_count, max_confidence = EXCLUDED.max_confidence, "
    "changes = EXCLUDED.changes, params_json = EXCLUDED.params_json, "
    "updated_ms = EXCLUDED.updated_ms";

namespace {

void WriteChanges(pg::Connection& c, const TileChangesRecord& t) {
  c.Query(
      "INSERT INTO tile_changes (tile, ix, iy, prior_version, new_count, "
      "removed_count, "
      "max_confidence, changes, params_json, updated_ms) VALUES "
      "($1,$2,$3,$4,$5,$6,$7,$8,$9,$10) " +
          std::string(pg_rows::kUpsertTileChanges),
      pg::Params()
          .Add(t.tile.ToString())
          .Add(int64_t{t.tile.ix()})
          .Add(int64_t{t.tile.iy()})
          .Add(t.prior_version)
          .Add(t.new_count)
          .Add(t.removed_count)
          .Add(t.max_confidence)
          .Add(t.changes)
          .Add(t.params_json)
          .Add(t.updated_ms));
}

void MarkJobTile(pg::Connection& c, int64_t job_id, const TileId& tile) {
  c.Query(
      "INSERT INTO job_tiles (job_id, tile) VALUES ($1,$2) ON CONFLICT DO "
      "NOTHING",
      pg::Params().Add(job_id).Add(tile.ToString()));
}

// A tile_changes row without its blob, as kChangesColumns select it (columns 0-7).
constexpr const char* kChangesColumns =
    "ix, iy, prior_version, new_count, removed_count, max_confidence, params_json, updated_ms";
TileChangesRecord TileChangesFromRow(const pg::Result& r, int row) {
  TileChangesRecord t;
  t.tile = TileId(static_cast<int32_t>(r.Int(row, 0)), static_cast<int32_t>(r.Int(row, 1)));
  t.prior_version = r.Int(row, 2);
  t.new_count = r.Int(row, 3);
  t.removed_count = r.Int(row, 4);
  t.max_confidence = r.Real(row, 5);
  t.params_json = r.Text(row, 6);
  t.updated_ms = r.Int(row, 7);
  return t;
}

std::vector<TileId> ReadTileIds(const pg::Result& r) {
  std::vector<TileId> out;
  for (int i = 0; i < r.rows(); ++i) {
    out.emplace_back(static_cast<int32_t>(r.Int(i, 0)), static_cast<int32_t>(r.Int(i, 1)));
  }
  return out;
}

}  // namespace

std::optional<TileStateRecord> PostgresTileStore::GetState(const TileId& tile) {
  auto c = Connect();
  // One snapshot for both reads (REPEATABLE READ), so the aggregate and its session set agree even
  // while another process applies a commit to the tile.
  pg::Transaction tx(*c);
  c->Exec("SET TRANSACTION ISOLATION LEVEL REPEATABLE READ READ ONLY");
  const pg::Result r = c->Query("SELECT aggregate, updated_ms FROM tile_state WHERE tile = $1",
                                pg::Params().Add(tile.ToString()));
  if (r.rows() == 0) return std::nullopt;
  TileStateRecord t;
  t.tile = tile;
  t.aggregate = r.Bytes(0, 0);
  t.updated_ms = r.Int(0, 1);
  const pg::Result s = c->Query(
      "SELECT session_id FROM tile_sessions WHERE "
      "tile = $1 ORDER BY session_id",
      pg::Params().Add(tile.ToString()));
  for (int i = 0; i < s.rows(); ++i) t.sessions.insert(s.Int(i, 0));
  tx.Commit();
  return t;
}

std::vector<TileId> PostgresTileStore::ListAggregated(const std::optional<Rect>& rect) {
  auto c = Connect();
  if (!rect) return ReadTileIds(c->Query("SELECT ix, iy FROM tile_state ORDER BY ix, iy"));
  pg::Params p;
  return ReadTileIds(
      c->Query("SELECT ix, iy FROM tile_state WHERE ix BETWEEN "
               "$1 AND $2 AND iy BETWEEN $3 AND $4 "
               "ORDER BY ix, iy",
               pg_rows::AddTileRange(p, *rect)));
}

void PostgresTileStore::ApplyUpdates(int64_t job_id, const std::vector<TileStateRecord>& states,
                                     int64_t now_ms) {
  auto c = Connect();
  pg::Transaction tx(*c);
  pg_rows::FenceJob(*c, job_id, worker());
  for (const TileStateRecord& st : states) {
    const std::string tile = st.tile.ToString();
    c->Query(
        "INSERT INTO tile_state (tile, ix, iy, aggregate, updated_ms) VALUES "
        "($1,$2,$3,$4,$5) "
        "ON CONFLICT (tile) DO UPDATE SET ix = EXCLUDED.ix, iy = EXCLUDED.iy, "
        "aggregate = EXCLUDED.aggregate, updated_ms = EXCLUDED.updated_ms",
        pg::Params()
            .Add(tile)
            .Add(int64_t{st.tile.ix()})
            .Add(int64_t{st.tile.iy()})
            .Add(st.aggregate)
            .Add(now_ms));
    c->Query("DELETE FROM tile_sessions WHERE tile = $1", pg::Params().Add(tile));
    for (int64_t session : st.sessions) {
      c->Query("INSERT INTO tile_sessions (tile, session_id) VALUES ($1,$2)",
               pg::Params().Add(tile).Add(session));
    }
    MarkJobTile(*c, job_id, st.tile);
  }
  tx.Commit();
}

void PostgresTileStore::ApplyChanges(int64_t job_id,
                                     const std::vector<TileChangesRecord>& changes) {
  auto c = Connect();
  pg::Transaction tx(*c);
  pg_rows::LockClusterFeed(*c, lifecycle_.get());
  if (job_id > 0) pg_rows::FenceJob(*c, job_id, worker());
  for (const TileChangesRecord& t : changes) {
    WriteChanges(*c, t);
    if (job_id > 0) MarkJobTile(*c, job_id, t.tile);
    pg_rows::ReconcileTileClusters(*c, lifecycle_.get(),
                                   {t.tile, job_id, t.updated_ms, &t, nullptr, 0, {}});
  }
  tx.Commit();
}

std::optional<TileChangesRecord> PostgresTileStore::GetChanges(const TileId& tile) {
  auto c = Connect();
  const pg::Result r = c->Query(
      std::string("SELECT ") + kChangesColumns + ", changes FROM tile_changes WHERE tile = $1",
      pg::Params().Add(tile.ToString()));
  if (r.rows() == 0) return std::nullopt;
  TileChangesRecord t = TileChangesFromRow(r, 0);
  t.changes = r.Bytes(0, 8);
  return t;
}

std::vector<TileChangesRecord> PostgresTileStore::ListChanged(const Rect& rect,
                                                              double min_confidence, int64_t limit,
                                                              int64_t offset, int64_t* total) {
  auto c = Connect();
  // count(*) OVER () gives the total beside the page in one statement (one snapshot).
  pg::Params p;
  pg_rows::AddTileRange(p, rect).Add(min_confidence).Add(limit).Add(offset);
  const pg::Result r = c->Query(std::string("SELECT ") + kChangesColumns +
                                    ", COUNT(*) OVER () FROM "
                                    "tile_changes WHERE ix BETWEEN $1 AND $2 "
                                    "AND iy BETWEEN $3 AND $4 AND max_confidence "
                                    ">= $5 AND (new_count + removed_count) > 0 "
                                    "ORDER BY ix, iy LIMIT $6 OFFSET $7",
                                p);
  std::vector<TileChangesRecord> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(TileChangesFromRow(r, i));
  if (!out.empty()) {
    *total = r.Int(0, 8);
    return out;
  }
  // An empty page (past the end, or limit 0) has no row to carry the total: count separately.
  pg::Params q;
  pg_rows::AddTileRange(q, rect).Add(min_confidence);
  *total = c->Query(
                "SELECT COUNT(*) FROM tile_changes WHERE ix BETWEEN $1 AND "
                "$2 AND iy BETWEEN $3 "
                "AND $4 AND max_confidence >= $5 AND (new_count + "
                "removed_count) > 0",
                q)
               .Int(0, 0);
  return out;
}

int64_t PostgresTileStore::ApplyRefresh(int64_t job_id, const PriorVersionRecord& meta,
                                        const std::vector<RefreshTileWrite>& tiles,
                                        const std::string& result_json, int64_t now_ms) {
  auto c = Connect();
  pg::Transaction tx(*c);
  pg_rows::LockClusterFeed(*c, lifecycle_.get());
  pg_rows::FenceJob(*c, job_id, worker());
  const int64_t previous = pg_rows::LockPriorVersions(*c);
  const int64_t version = previous + 1;
  c->Query(
      "INSERT INTO prior_versions (version, created_ms, source, parent, "
      "note, job_id) "
      "VALUES ($1,$2,$3,$4,$5,$6)",
      pg::Params()
          .Add(version)
          .Add(now_ms)
          .Add(ToString(PriorSource::kRefresh))
          .Add(previous)
          .Add(meta.note)
          .Add(job_id));
  for (const RefreshTileWrite& t : tiles) {
    const std::string tile = t.tile.ToString();
    pg_rows::InsertPriorTile(*c, version, tile, t.tile.ix(), t.tile.iy(), t.point_count, t.points);
    // Before the tile's sessions are reset below: the lifecycle reads them.
    pg_rows::ReconcileTileClusters(*c, lifecycle_.get(),
                                   {t.tile, job_id, now_ms, nullptr, &t, version, {}});
    // The merged changes are now part of the prior: the tile starts aggregating afresh.
    for (const char* q :
         {"DELETE FROM tile_state WHERE tile = $1", "DELETE FROM tile_sessions WHERE tile = $1",
          "DELETE FROM tile_changes WHERE tile = $1"}) {
      c->Query(q, pg::Params().Add(tile));
    }
    c->Query(
        "INSERT INTO refresh_log (job_id, tile, from_version, to_version, "
        "added, removed) "
        "VALUES ($1,$2,$3,$4,$5,$6)",
        pg::Params()
            .Add(job_id)
            .Add(tile)
            .Add(t.from_version)
            .Add(version)
            .Add(t.added)
            .Add(t.removed));
  }
  // The job stays running (it reclassifies the neighbours next); its result is kept so that a
  // resumed job finds the version it made instead of making another.
  c->Query(
      "UPDATE jobs SET progress = 0.9, message = $1, result_json = $2 "
      "WHERE id = $3",
      pg::Params()
          .Add("prior version " + std::to_string(version) + " created; reclassifying neighbours")
          .Add(result_json)
          .Add(job_id));
  tx.Commit();
  return version;
}

std::optional<std::string> PostgresTileStore::GetSetting(const std::string& key) {
  auto c = Connect();
  const pg::Result r = c->Query("SELECT value FROM settings WHERE key = $1", pg::Params().Add(key));
  if (r.rows() == 0) return std::nullopt;
  return r.Text(0, 0);
}

void PostgresTileStore::PutSetting(const std::string& key, const std::string& value) {
  auto c = Connect();
  c->Query(
      "INSERT INTO settings (key, value) VALUES ($1,$2) "
      "ON CONFLICT (key) DO UPDATE SET value = EXCLUDED.value",
      pg::Params().Add(key).Add(value));
}

}  // namespace mapdelta::server
