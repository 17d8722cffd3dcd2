// SQLite tile store: per-tile aggregation, classification, refresh, settings.
#include "storage_sqlite.hpp"

namespace mapdelta::server {

std::optional<TileStateRecord> SqliteTileStore::GetState(const TileId& tile) {
  auto lock = Lock();
  sql::Stmt s(db(), "SELECT aggregate, updated_ms FROM tile_state WHERE tile = ?");
  s.Bind(1, tile.ToString());
  if (!s.Step()) return std::nullopt;
  TileStateRecord r;
  r.tile = tile;
  r.aggregate = s.Blob(0);
  r.updated_ms = s.Int(1);
  sql::Stmt q(db(), "SELECT session_id FROM tile_sessions WHERE tile = ? ORDER BY session_id");
  q.Bind(1, tile.ToString());
  while (q.Step()) r.sessions.insert(q.Int(0));
  return r;
}

std::vector<TileId> SqliteTileStore::ListAggregated(const std::optional<Rect>& rect) {
  auto lock = Lock();
  std::vector<TileId> out;
  if (rect) {
    sql::Stmt s(db(),
                "SELECT ix, iy FROM tile_state WHERE ix BETWEEN ? AND ? AND iy BETWEEN ? AND ? "
                "ORDER BY ix, iy");
    BindTileRange(s, 1, *rect);
    while (s.Step())
      out.emplace_back(static_cast<int32_t>(s.Int(0)), static_cast<int32_t>(s.Int(1)));
  } else {
    sql::Stmt s(db(), "SELECT ix, iy FROM tile_state ORDER BY ix, iy");
    while (s.Step())
      out.emplace_back(static_cast<int32_t>(s.Int(0)), static_cast<int32_t>(s.Int(1)));
  }
  return out;
}

void SqliteTileStore::WriteChangesLocked(const TileChangesRecord& c) {
  sql::Stmt s(db(),
              "INSERT OR REPLACE INTO tile_changes (tile, ix, iy, prior_version, new_count, "
              "removed_count, max_confidence, changes, params_json, updated_ms) "
              "VALUES (?,?,?,?,?,?,?,?,?,?)");
  s.Bind(1, c.tile.ToString())
      .Bind(2, int64_t{c.tile.ix()})
      .Bind(3, int64_t{c.tile.iy()})
      .Bind(4, c.prior_version)
      .Bind(5, c.new_count)
      .Bind(6, c.removed_count)
      .Bind(7, c.max_confidence)
      .Bind(8, c.changes)
      .Bind(9, c.params_json)
      .Bind(10, c.updated_ms);
  s.Run();
}

void SqliteTileStore::MarkJobTileLocked(int64_t job_id, const TileId& tile) {
  sql::Stmt s(db(), "INSERT OR IGNORE INTO job_tiles (job_id, tile) VALUES (?,?)");
  s.Bind(1, job_id).Bind(2, tile.ToString()).Run();
}

void SqliteTileStore::ApplyUpdates(int64_t job_id, const std::vector<TileStateRecord>& states,
                                   int64_t now_ms) {
  auto lock = Lock();
  sql::Transaction tx(db());
  for (const TileStateRecord& st : states) {
    const std::string tile = st.tile.ToString();
    sql::Stmt s(db(),
                "INSERT OR REPLACE INTO tile_state (tile, ix, iy, aggregate, updated_ms) "
                "VALUES (?,?,?,?,?)");
    s.Bind(1, tile)
        .Bind(2, int64_t{st.tile.ix()})
        .Bind(3, int64_t{st.tile.iy()})
        .Bind(4, st.aggregate)
        .Bind(5, now_ms)
        .Run();
    sql::Stmt d(db(), "DELETE FROM tile_sessions WHERE tile = ?");
    d.Bind(1, tile).Run();
    sql::Stmt i(db(), "INSERT INTO tile_sessions (tile, session_id) VALUES (?,?)");
    for (int64_t session : st.sessions) {
      i.Reset();
      i.Bind(1, tile).Bind(2, session).Run();
    }
    MarkJobTileLocked(job_id, st.tile);
  }
  tx.Commit();
}

void SqliteTileStore::ApplyChanges(int64_t job_id, const std::vector<TileChangesRecord>& changes) {
  auto lock = Lock();
  sql::Transaction tx(db());
  for (const TileChangesRecord& c : changes) {
    WriteChangesLocked(c);
    if (job_id > 0) MarkJobTileLocked(job_id, c.tile);
    ReconcileTileClustersSqlite(db(), lifecycle_.get(),
                                {c.tile, job_id, c.updated_ms, &c, nullptr, 0, {}});
  }
  tx.Commit();
}

std::optional<TileChangesRecord> SqliteTileStore::GetChanges(const TileId& tile) {
  auto lock = Lock();
  sql::Stmt s(db(),
              "SELECT prior_version, new_count, removed_count, max_confidence, changes, "
              "params_json, updated_ms FROM tile_changes WHERE tile = ?");
  s.Bind(1, tile.ToString());
  if (!s.Step()) return std::nullopt;
  TileChangesRecord c;
  c.tile = tile;
  c.prior_version = s.Int(0);
  c.new_count = s.Int(1);
  c.removed_count = s.Int(2);
  c.max_confidence = s.Real(3);
  c.changes = s.Blob(4);
  c.params_json = s.Text(5);
  c.updated_ms = s.Int(6);
  return c;
}

std::vector<TileChangesRecord> SqliteTileStore::ListChanged(const Rect& rect, double min_confidence,
                                                            int64_t limit, int64_t offset,
                                                            int64_t* total) {
  auto lock = Lock();
  const char* where =
      " FROM tile_changes WHERE ix BETWEEN ? AND ? AND iy BETWEEN ? AND ? "
      "AND max_confidence >= ? AND (new_count + removed_count) > 0";
  {
    sql::Stmt c(db(), std::string("SELECT COUNT(*)") + where);
    BindTileRange(c, 1, rect);
    c.Bind(5, min_confidence);
    c.Step();
    *total = c.Int(0);
  }
  sql::Stmt s(db(), std::string("SELECT ix, iy, prior_version, new_count, removed_count, "
                                "max_confidence, params_json, updated_ms") +
                        where + " ORDER BY ix, iy LIMIT ? OFFSET ?");
  BindTileRange(s, 1, rect);
  s.Bind(5, min_confidence).Bind(6, limit).Bind(7, offset);
  std::vector<TileChangesRecord> out;
  while (s.Step()) {
    TileChangesRecord c;
    c.tile = TileId(static_cast<int32_t>(s.Int(0)), static_cast<int32_t>(s.Int(1)));
    c.prior_version = s.Int(2);
    c.new_count = s.Int(3);
    c.removed_count = s.Int(4);
    c.max_confidence = s.Real(5);
    c.params_json = s.Text(6);
    c.updated_ms = s.Int(7);
    out.push_back(c);
  }
  return out;
}

int64_t SqliteTileStore::ApplyRefresh(int64_t job_id, const PriorVersionRecord& meta,
                                      const std::vector<RefreshTileWrite>& tiles,
                                      const std::string& result_json, int64_t now_ms) {
  auto lock = Lock();
  sql::Transaction tx(db());
  int64_t previous = 0;
  {
    sql::Stmt s(db(), "SELECT COALESCE(MAX(version), 0) FROM prior_versions");
    s.Step();
    previous = s.Int(0);
  }
  const int64_t version = previous + 1;
  {
    sql::Stmt s(db(),
                "INSERT INTO prior_versions (version, created_ms, source, parent, note, job_id) "
                "VALUES (?,?,?,?,?,?)");
    s.Bind(1, version)
        .Bind(2, now_ms)
        .Bind(3, ToString(PriorSource::kRefresh))
        .Bind(4, previous)
        .Bind(5, meta.note)
        .Bind(6, job_id)
        .Run();
  }
  for (const RefreshTileWrite& t : tiles) {
    const std::string tile = t.tile.ToString();
    // Before the tile's sessions are reset below: the lifecycle reads them.
    ReconcileTileClustersSqlite(db(), lifecycle_.get(),
                                {t.tile, job_id, now_ms, nullptr, &t, version, {}});
    sql::Stmt p(db(),
                "INSERT INTO prior_tiles (version, tile, ix, iy, point_count, points) "
                "VALUES (?,?,?,?,?,?)");
    p.Bind(1, version)
        .Bind(2, tile)
        .Bind(3, int64_t{t.tile.ix()})
        .Bind(4, int64_t{t.tile.iy()})
        .Bind(5, t.point_count)
        .Bind(6, t.points)
        .Run();
    // The merged changes are now part of the prior: the tile starts aggregating afresh.
    for (const char* q :
         {"DELETE FROM tile_state WHERE tile = ?", "DELETE FROM tile_sessions WHERE tile = ?",
          "DELETE FROM tile_changes WHERE tile = ?"}) {
      sql::Stmt d(db(), q);
      d.Bind(1, tile).Run();
    }
    sql::Stmt l(db(),
                "INSERT INTO refresh_log (job_id, tile, from_version, to_version, added, removed) "
                "VALUES (?,?,?,?,?,?)");
    l.Bind(1, job_id)
        .Bind(2, tile)
        .Bind(3, t.from_version)
        .Bind(4, version)
        .Bind(5, t.added)
        .Bind(6, t.removed)
        .Run();
  }
  // The job stays running (it reclassifies the neighbours next); its result is kept so that
  // a resumed job finds the version it made instead of making another.
  sql::Stmt f(db(), "UPDATE jobs SET progress = 0.9, message = ?, result_json = ? WHERE id = ?");
  f.Bind(1, "prior version " + std::to_string(version) + " created; reclassifying neighbours")
      .Bind(2, result_json)
      .Bind(3, job_id)
      .Run();
  tx.Commit();
  return version;
}

std::optional<std::string> SqliteTileStore::GetSetting(const std::string& key) {
  auto lock = Lock();
  sql::Stmt s(db(), "SELECT value FROM settings WHERE key = ?");
  s.Bind(1, key);
  if (!s.Step()) return std::nullopt;
  return s.Text(0);
}

void SqliteTileStore::PutSetting(const std::string& key, const std::string& value) {
  auto lock = Lock();
  sql::Stmt s(db(), "INSERT OR REPLACE INTO settings (key, value) VALUES (?,?)");
  s.Bind(1, key).Bind(2, value).Run();
}

}  // namespace mapdelta::server
