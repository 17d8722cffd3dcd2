// SQLite storage: jobs, per-tile aggregation, changes and refresh.
#include "storage_sqlite.hpp"

#include "mapdelta/common/error.hpp"

namespace mapdelta::server {

namespace {
constexpr const char* kJobColumns =
    "id, type, state, params_json, progress, message, result_json, cancel_requested, attempts, "
    "created_ms, started_ms, finished_ms";

void BindTileRange(sql::Stmt& s, int first, const Rect& r) {
  s.Bind(first, static_cast<int64_t>(r.min_x)).Bind(first + 1, static_cast<int64_t>(r.max_x))
      .Bind(first + 2, static_cast<int64_t>(r.min_y)).Bind(first + 3, static_cast<int64_t>(r.max_y));
}
}  // namespace

JobRecord SqliteStorage::ReadJob(sql::Stmt& s) {
  JobRecord j;
  j.id = s.Int(0);
  j.type = s.Text(1);
  j.state = s.Text(2);
  j.params_json = s.Text(3);
  j.progress = s.Real(4);
  j.message = s.Text(5);
  j.result_json = s.OptText(6);
  j.cancel_requested = s.Int(7) != 0;
  j.attempts = s.Int(8);
  j.created_ms = s.Int(9);
  if (!s.IsNull(10)) j.started_ms = s.Int(10);
  if (!s.IsNull(11)) j.finished_ms = s.Int(11);
  return j;
}

int64_t SqliteStorage::CreateJob(const std::string& type, const std::string& params_json,
                                 int64_t now_ms) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, "INSERT INTO jobs (type, state, params_json, created_ms) VALUES (?,'queued',?,?)");
  s.Bind(1, type).Bind(2, params_json).Bind(3, now_ms).Run();
  return db_.LastInsertId();
}

std::optional<JobRecord> SqliteStorage::GetJob(int64_t id) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?");
  s.Bind(1, id);
  if (!s.Step()) return std::nullopt;
  return ReadJob(s);
}

std::vector<JobRecord> SqliteStorage::ListJobs(int64_t limit, int64_t offset) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, std::string("SELECT ") + kJobColumns +
                       " FROM jobs ORDER BY id DESC LIMIT ? OFFSET ?");
  s.Bind(1, limit).Bind(2, offset);
  std::vector<JobRecord> out;
  while (s.Step()) out.push_back(ReadJob(s));
  return out;
}

std::optional<JobRecord> SqliteStorage::ClaimNextJob(int64_t now_ms) {
  std::lock_guard lock(mutex_);
  sql::Transaction tx(db_);
  int64_t id = 0;
  {
    sql::Stmt s(db_, "SELECT id FROM jobs WHERE state = 'queued' ORDER BY id LIMIT 1");
    if (!s.Step()) return std::nullopt;
    id = s.Int(0);
  }
  sql::Stmt u(db_,
              "UPDATE jobs SET state = 'running', attempts = attempts + 1, "
              "started_ms = COALESCE(started_ms, ?) WHERE id = ?");
  u.Bind(1, now_ms).Bind(2, id).Run();
  sql::Stmt s(db_, std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?");
  s.Bind(1, id);
  s.Step();
  JobRecord j = ReadJob(s);
  tx.Commit();
  return j;
}

void SqliteStorage::UpdateJobProgress(int64_t id, double progress, const std::string& message) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, "UPDATE jobs SET progress = ?, message = ? WHERE id = ?");
  s.Bind(1, progress).Bind(2, message).Bind(3, id).Run();
}

void SqliteStorage::FinishJob(int64_t id, const std::string& state, const std::string& message,
                              const std::optional<std::string>& result_json, int64_t now_ms) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_,
              "UPDATE jobs SET state = ?, message = ?, result_json = ?, finished_ms = ?, "
              "progress = CASE WHEN ? = 'succeeded' THEN 1.0 ELSE progress END WHERE id = ?");
  s.Bind(1, state).Bind(2, message).Bind(3, result_json).Bind(4, now_ms).Bind(5, state)
      .Bind(6, id).Run();
}

std::optional<std::string> SqliteStorage::RequestCancel(int64_t id, int64_t now_ms) {
  std::lock_guard lock(mutex_);
  sql::Transaction tx(db_);
  std::string state;
  {
    sql::Stmt s(db_, "SELECT state FROM jobs WHERE id = ?");
    s.Bind(1, id);
    if (!s.Step()) return std::nullopt;
    state = s.Text(0);
  }
  if (state == "queued") {
    sql::Stmt u(db_,
                "UPDATE jobs SET state = 'cancelled', cancel_requested = 1, finished_ms = ?, "
                "message = 'cancelled before it started' WHERE id = ?");
    u.Bind(1, now_ms).Bind(2, id).Run();
    // A cancelled commit leaves its session open so that the vehicle can commit again.
    sql::Stmt r(db_, "UPDATE sessions SET state = 'open', job_id = NULL WHERE job_id = ?");
    r.Bind(1, id).Run();
    state = "cancelled";
  } else if (state == "running") {
    sql::Stmt u(db_, "UPDATE jobs SET cancel_requested = 1 WHERE id = ?");
    u.Bind(1, id).Run();
  }
  tx.Commit();
  return state;
}

bool SqliteStorage::IsCancelRequested(int64_t id) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, "SELECT cancel_requested FROM jobs WHERE id = ?");
  s.Bind(1, id);
  return s.Step() && s.Int(0) != 0;
}

int SqliteStorage::RequeueInterruptedJobs() {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_,
              "UPDATE jobs SET state = 'queued', message = 'resumed after restart' "
              "WHERE state = 'running'");
  s.Run();
  return db_.Changes();
}

std::set<std::string> SqliteStorage::JobTilesDone(int64_t job_id) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, "SELECT tile FROM job_tiles WHERE job_id = ?");
  s.Bind(1, job_id);
  std::set<std::string> out;
  while (s.Step()) out.insert(s.Text(0));
  return out;
}

std::vector<std::pair<std::string, int64_t>> SqliteStorage::CountJobsByState() {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, "SELECT state, COUNT(*) FROM jobs GROUP BY state");
  std::vector<std::pair<std::string, int64_t>> out;
  while (s.Step()) out.emplace_back(s.Text(0), s.Int(1));
  return out;
}

// ---------------------------------------------------------------- tiles

std::optional<TileStateRecord> SqliteStorage::GetTileState(const TileId& tile) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, "SELECT aggregate, updated_ms FROM tile_state WHERE tile = ?");
  s.Bind(1, tile.ToString());
  if (!s.Step()) return std::nullopt;
  TileStateRecord r;
  r.tile = tile;
  r.aggregate = s.Blob(0);
  r.updated_ms = s.Int(1);
  sql::Stmt q(db_, "SELECT session_id FROM tile_sessions WHERE tile = ? ORDER BY session_id");
  q.Bind(1, tile.ToString());
  while (q.Step()) r.sessions.insert(q.Int(0));
  return r;
}

std::vector<TileId> SqliteStorage::ListAggregatedTiles(const std::optional<Rect>& rect) {
  std::lock_guard lock(mutex_);
  std::vector<TileId> out;
  if (rect) {
    sql::Stmt s(db_,
                "SELECT ix, iy FROM tile_state WHERE ix BETWEEN ? AND ? AND iy BETWEEN ? AND ? "
                "ORDER BY ix, iy");
    BindTileRange(s, 1, *rect);
    while (s.Step()) out.emplace_back(static_cast<int32_t>(s.Int(0)), static_cast<int32_t>(s.Int(1)));
  } else {
    sql::Stmt s(db_, "SELECT ix, iy FROM tile_state ORDER BY ix, iy");
    while (s.Step()) out.emplace_back(static_cast<int32_t>(s.Int(0)), static_cast<int32_t>(s.Int(1)));
  }
  return out;
}

void SqliteStorage::WriteChangesLocked(const TileChangesRecord& c) {
  sql::Stmt s(db_,
              "INSERT OR REPLACE INTO tile_changes (tile, ix, iy, prior_version, new_count, "
              "removed_count, max_confidence, changes, params_json, updated_ms) "
              "VALUES (?,?,?,?,?,?,?,?,?,?)");
  s.Bind(1, c.tile.ToString()).Bind(2, int64_t{c.tile.ix()}).Bind(3, int64_t{c.tile.iy()})
      .Bind(4, c.prior_version).Bind(5, c.new_count).Bind(6, c.removed_count)
      .Bind(7, c.max_confidence).Bind(8, c.changes).Bind(9, c.params_json).Bind(10, c.updated_ms);
  s.Run();
}

void SqliteStorage::MarkJobTileLocked(int64_t job_id, const TileId& tile) {
  sql::Stmt s(db_, "INSERT OR IGNORE INTO job_tiles (job_id, tile) VALUES (?,?)");
  s.Bind(1, job_id).Bind(2, tile.ToString()).Run();
}

void SqliteStorage::ApplyTileUpdates(int64_t job_id, const std::vector<TileStateRecord>& states,
                                     int64_t now_ms) {
  std::lock_guard lock(mutex_);
  sql::Transaction tx(db_);
  for (const TileStateRecord& st : states) {
    const std::string tile = st.tile.ToString();
    sql::Stmt s(db_,
                "INSERT OR REPLACE INTO tile_state (tile, ix, iy, aggregate, updated_ms) "
                "VALUES (?,?,?,?,?)");
    s.Bind(1, tile).Bind(2, int64_t{st.tile.ix()}).Bind(3, int64_t{st.tile.iy()})
        .Bind(4, st.aggregate).Bind(5, now_ms).Run();
    sql::Stmt d(db_, "DELETE FROM tile_sessions WHERE tile = ?");
    d.Bind(1, tile).Run();
    sql::Stmt i(db_, "INSERT INTO tile_sessions (tile, session_id) VALUES (?,?)");
    for (int64_t session : st.sessions) {
      i.Reset();
      i.Bind(1, tile).Bind(2, session).Run();
    }
    MarkJobTileLocked(job_id, st.tile);
  }
  tx.Commit();
}

void SqliteStorage::ApplyTileChanges(int64_t job_id, const std::vector<TileChangesRecord>& changes) {
  std::lock_guard lock(mutex_);
  sql::Transaction tx(db_);
  for (const TileChangesRecord& c : changes) {
    WriteChangesLocked(c);
    if (job_id > 0) MarkJobTileLocked(job_id, c.tile);
  }
  tx.Commit();
}

std::optional<TileChangesRecord> SqliteStorage::GetTileChanges(const TileId& tile) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_,
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

std::vector<TileChangesRecord> SqliteStorage::ListChangedTiles(const Rect& rect,
                                                               double min_confidence,
                                                               int64_t limit, int64_t offset,
                                                               int64_t* total) {
  std::lock_guard lock(mutex_);
  const char* where =
      " FROM tile_changes WHERE ix BETWEEN ? AND ? AND iy BETWEEN ? AND ? "
      "AND max_confidence >= ? AND (new_count + removed_count) > 0";
  {
    sql::Stmt c(db_, std::string("SELECT COUNT(*)") + where);
    BindTileRange(c, 1, rect);
    c.Bind(5, min_confidence);
    c.Step();
    *total = c.Int(0);
  }
  sql::Stmt s(db_, std::string("SELECT ix, iy, prior_version, new_count, removed_count, "
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

int64_t SqliteStorage::ApplyRefresh(int64_t job_id, const PriorVersionRecord& meta,
                                    const std::vector<RefreshTileWrite>& tiles,
                                    const std::string& result_json, int64_t now_ms) {
  std::lock_guard lock(mutex_);
  sql::Transaction tx(db_);
  int64_t previous = 0;
  {
    sql::Stmt s(db_, "SELECT COALESCE(MAX(version), 0) FROM prior_versions");
    s.Step();
    previous = s.Int(0);
  }
  const int64_t version = previous + 1;
  {
    sql::Stmt s(db_,
                "INSERT INTO prior_versions (version, created_ms, source, parent, note, job_id) "
                "VALUES (?,?,'refresh',?,?,?)");
    s.Bind(1, version).Bind(2, now_ms).Bind(3, previous).Bind(4, meta.note).Bind(5, job_id).Run();
  }
  for (const RefreshTileWrite& t : tiles) {
    const std::string tile = t.tile.ToString();
    sql::Stmt p(db_,
                "INSERT INTO prior_tiles (version, tile, ix, iy, point_count, points) "
                "VALUES (?,?,?,?,?,?)");
    p.Bind(1, version).Bind(2, tile).Bind(3, int64_t{t.tile.ix()}).Bind(4, int64_t{t.tile.iy()})
        .Bind(5, t.point_count).Bind(6, t.points).Run();
    // The merged changes are now part of the prior: the tile starts aggregating afresh.
    for (const char* q : {"DELETE FROM tile_state WHERE tile = ?",
                          "DELETE FROM tile_sessions WHERE tile = ?",
                          "DELETE FROM tile_changes WHERE tile = ?"}) {
      sql::Stmt d(db_, q);
      d.Bind(1, tile).Run();
    }
    sql::Stmt l(db_,
                "INSERT INTO refresh_log (job_id, tile, from_version, to_version, added, removed) "
                "VALUES (?,?,?,?,?,?)");
    l.Bind(1, job_id).Bind(2, tile).Bind(3, t.from_version).Bind(4, version).Bind(5, t.added)
        .Bind(6, t.removed).Run();
  }
  // The job stays running (it reclassifies the neighbours next); its result is kept so that
  // a resumed job finds the version it made instead of making another.
  sql::Stmt f(db_, "UPDATE jobs SET progress = 0.9, message = ?, result_json = ? WHERE id = ?");
  f.Bind(1, "prior version " + std::to_string(version) + " created; reclassifying neighbours")
      .Bind(2, result_json).Bind(3, job_id).Run();
  (void)now_ms;
  tx.Commit();
  return version;
}

}  // namespace mapdelta::server
