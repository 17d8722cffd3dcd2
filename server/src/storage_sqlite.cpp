// SQLite storage: schema migrations, tokens, prior versions, sessions and keyframes.
// Jobs and per-tile state are in storage_sqlite_tiles.cpp.
#include "storage_sqlite.hpp"

#include <cmath>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "migrations.hpp"

namespace mapdelta::server {

std::string_view ToString(Role role) {
  switch (role) {
    case Role::kVehicle: return "vehicle";
    case Role::kReader: return "reader";
    case Role::kAdmin: return "admin";
  }
  return "?";
}

std::optional<Role> ParseRole(std::string_view text) {
  if (text == "vehicle") return Role::kVehicle;
  if (text == "reader") return Role::kReader;
  if (text == "admin") return Role::kAdmin;
  return std::nullopt;
}

int KnownSchemaVersion() {
  const auto& all = EmbeddedMigrations();
  return all.empty() ? 0 : all.back().version;
}

std::unique_ptr<Storage> OpenSqliteStorage(const std::string& path) {
  return std::make_unique<SqliteStorage>(path);
}

SqliteStorage::SqliteStorage(const std::string& path) : db_(path) { Migrate(); }

void SqliteStorage::Migrate() {
  std::lock_guard lock(mutex_);
  sql::Transaction tx(db_);
  db_.Exec(
      "CREATE TABLE IF NOT EXISTS schema_migrations (version INTEGER PRIMARY KEY, "
      "name TEXT NOT NULL, applied_ms INTEGER NOT NULL)");
  int64_t current = 0;
  {
    sql::Stmt s(db_, "SELECT COALESCE(MAX(version), 0) FROM schema_migrations");
    if (s.Step()) current = s.Int(0);
  }
  if (current > KnownSchemaVersion()) {
    throw Error(ErrorCode::kUnsupported,
                "database schema version " + std::to_string(current) +
                    " is newer than this server knows (" + std::to_string(KnownSchemaVersion()) +
                    "); upgrade mapdelta-server");
  }
  for (const Migration& m : EmbeddedMigrations()) {
    if (m.version <= current) continue;
    MD_LOG(kInfo, "applying migration " << m.name);
    db_.Exec(m.sql);
    sql::Stmt s(db_, "INSERT INTO schema_migrations VALUES (?, ?, strftime('%s','now')*1000)");
    s.Bind(1, int64_t{m.version}).Bind(2, m.name).Run();
  }
  tx.Commit();
}

// ---------------------------------------------------------------- tokens

void SqliteStorage::InsertToken(const TokenRecord& t, const std::string& hash) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, "INSERT INTO tokens (id, name, role, hash, created_ms) VALUES (?,?,?,?,?)");
  s.Bind(1, t.id).Bind(2, t.name).Bind(3, ToString(t.role)).Bind(4, hash).Bind(5, t.created_ms);
  s.Run();
}

namespace {
TokenRecord ReadToken(sql::Stmt& s) {
  TokenRecord t;
  t.id = s.Text(0);
  t.name = s.Text(1);
  t.role = ParseRole(s.Text(2)).value_or(Role::kReader);
  t.created_ms = s.Int(3);
  if (!s.IsNull(4)) t.revoked_ms = s.Int(4);
  return t;
}
}  // namespace

std::optional<TokenRecord> SqliteStorage::FindActiveTokenByHash(const std::string& hash) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_,
              "SELECT id, name, role, created_ms, revoked_ms FROM tokens "
              "WHERE hash = ? AND revoked_ms IS NULL");
  s.Bind(1, hash);
  if (!s.Step()) return std::nullopt;
  return ReadToken(s);
}

bool SqliteStorage::RevokeToken(const std::string& id, int64_t now_ms) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, "UPDATE tokens SET revoked_ms = ? WHERE id = ? AND revoked_ms IS NULL");
  s.Bind(1, now_ms).Bind(2, id).Run();
  return db_.Changes() > 0;
}

std::vector<TokenRecord> SqliteStorage::ListTokens() {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, "SELECT id, name, role, created_ms, revoked_ms FROM tokens ORDER BY created_ms");
  std::vector<TokenRecord> out;
  while (s.Step()) out.push_back(ReadToken(s));
  return out;
}

// ---------------------------------------------------------------- prior map

int64_t SqliteStorage::CreatePriorVersion(const PriorVersionRecord& meta,
                                          const std::vector<PriorTileRecord>& tiles,
                                          bool replace_all) {
  std::lock_guard lock(mutex_);
  sql::Transaction tx(db_);
  int64_t previous = 0;
  {
    sql::Stmt s(db_, "SELECT COALESCE(MAX(version), 0) FROM prior_versions");
    if (s.Step()) previous = s.Int(0);
  }
  const int64_t version = previous + 1;
  {
    sql::Stmt s(db_,
                "INSERT INTO prior_versions (version, created_ms, source, parent, note, job_id) "
                "VALUES (?,?,?,?,?,?)");
    s.Bind(1, version).Bind(2, meta.created_ms).Bind(3, meta.source);
    if (previous > 0) s.Bind(4, previous); else s.BindNull(4);
    s.Bind(5, meta.note);
    if (meta.job_id) s.Bind(6, *meta.job_id); else s.BindNull(6);
    s.Run();
  }
  sql::Stmt ins(db_,
                "INSERT INTO prior_tiles (version, tile, ix, iy, point_count, points) "
                "VALUES (?,?,?,?,?,?)");
  std::set<std::string> written;
  for (const PriorTileRecord& t : tiles) {
    ins.Reset();
    ins.Bind(1, version).Bind(2, t.tile.ToString()).Bind(3, int64_t{t.tile.ix()})
        .Bind(4, int64_t{t.tile.iy()}).Bind(5, t.point_count).Bind(6, t.points);
    ins.Run();
    written.insert(t.tile.ToString());
  }
  if (replace_all && previous > 0) {
    // Tiles that had points before but are absent now must read as empty at this version.
    sql::Stmt s(db_,
                "SELECT tile, ix, iy FROM prior_tiles p WHERE version = (SELECT MAX(version) "
                "FROM prior_tiles q WHERE q.tile = p.tile AND q.version <= ?) AND point_count > 0");
    s.Bind(1, previous);
    std::vector<std::tuple<std::string, int64_t, int64_t>> gone;
    while (s.Step()) {
      if (!written.count(s.Text(0))) gone.emplace_back(s.Text(0), s.Int(1), s.Int(2));
    }
    for (const auto& [tile, ix, iy] : gone) {
      ins.Reset();
      ins.Bind(1, version).Bind(2, tile).Bind(3, ix).Bind(4, iy).Bind(5, int64_t{0})
          .Bind(6, Bytes{});
      ins.Run();
    }
  }
  tx.Commit();
  return version;
}

std::optional<int64_t> SqliteStorage::LatestPriorVersion() {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, "SELECT MAX(version) FROM prior_versions");
  if (!s.Step() || s.IsNull(0)) return std::nullopt;
  return s.Int(0);
}

std::vector<PriorVersionRecord> SqliteStorage::ListPriorVersions() {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_,
              "SELECT version, created_ms, source, parent, note, job_id FROM prior_versions "
              "ORDER BY version");
  std::vector<PriorVersionRecord> out;
  while (s.Step()) {
    PriorVersionRecord r;
    r.version = s.Int(0);
    r.created_ms = s.Int(1);
    r.source = s.Text(2);
    if (!s.IsNull(3)) r.parent = s.Int(3);
    r.note = s.Text(4);
    if (!s.IsNull(5)) r.job_id = s.Int(5);
    out.push_back(r);
  }
  return out;
}

std::optional<PriorTileRecord> SqliteStorage::GetPriorTile(const TileId& tile, int64_t version) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_,
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

std::vector<PriorTileRecord> SqliteStorage::ListPriorTiles(const Rect& rect, int64_t version) {
  std::lock_guard lock(mutex_);
  // rect is in tile indices here (the service converts metres to tile ranges).
  sql::Stmt s(db_,
              "SELECT tile, ix, iy, version, point_count FROM prior_tiles p "
              "WHERE ix BETWEEN ? AND ? AND iy BETWEEN ? AND ? AND version = (SELECT MAX(version) "
              "FROM prior_tiles q WHERE q.tile = p.tile AND q.version <= ?) AND point_count > 0 "
              "ORDER BY ix, iy");
  s.Bind(1, static_cast<int64_t>(rect.min_x)).Bind(2, static_cast<int64_t>(rect.max_x))
      .Bind(3, static_cast<int64_t>(rect.min_y)).Bind(4, static_cast<int64_t>(rect.max_y))
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

// ---------------------------------------------------------------- sessions

int64_t SqliteStorage::CreateSession(const SessionRecord& r) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_,
              "INSERT INTO sessions (vehicle_id, camera_json, depth_scale, state, created_ms) "
              "VALUES (?,?,?,'open',?)");
  s.Bind(1, r.vehicle_id).Bind(2, r.camera_json).Bind(3, r.depth_scale).Bind(4, r.created_ms);
  s.Run();
  return db_.LastInsertId();
}

std::optional<SessionRecord> SqliteStorage::GetSession(int64_t id) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_,
              "SELECT id, vehicle_id, camera_json, depth_scale, state, created_ms, committed_ms, "
              "job_id, registration_json, (SELECT COUNT(*) FROM keyframes WHERE session_id = id), "
              "(SELECT COALESCE(MAX(t_ns), 0) FROM keyframes WHERE session_id = id) "
              "FROM sessions WHERE id = ?");
  s.Bind(1, id);
  if (!s.Step()) return std::nullopt;
  SessionRecord r;
  r.id = s.Int(0);
  r.vehicle_id = s.Text(1);
  r.camera_json = s.Text(2);
  r.depth_scale = s.Real(3);
  r.state = s.Text(4);
  r.created_ms = s.Int(5);
  if (!s.IsNull(6)) r.committed_ms = s.Int(6);
  if (!s.IsNull(7)) r.job_id = s.Int(7);
  r.registration_json = s.OptText(8);
  r.keyframe_count = s.Int(9);
  r.last_t_ns = s.Int(10);
  return r;
}

PutKeyframeOutcome SqliteStorage::PutKeyframe(int64_t session_id, const KeyframeRecord& k) {
  std::lock_guard lock(mutex_);
  sql::Transaction tx(db_);
  {
    sql::Stmt s(db_, "SELECT state FROM sessions WHERE id = ?");
    s.Bind(1, session_id);
    if (!s.Step()) return PutKeyframeOutcome::kNoSession;
    if (s.Text(0) != "open") {
      // A retry of an already-stored keyframe after commit is still a harmless repeat.
      sql::Stmt e(db_, "SELECT content_sha FROM keyframes WHERE session_id = ? AND seq = ?");
      e.Bind(1, session_id).Bind(2, k.seq);
      if (e.Step() && e.Text(0) == k.content_sha) return PutKeyframeOutcome::kIdentical;
      return PutKeyframeOutcome::kSessionNotOpen;
    }
  }
  {
    sql::Stmt s(db_, "SELECT content_sha FROM keyframes WHERE session_id = ? AND seq = ?");
    s.Bind(1, session_id).Bind(2, k.seq);
    if (s.Step()) {
      return s.Text(0) == k.content_sha ? PutKeyframeOutcome::kIdentical
                                        : PutKeyframeOutcome::kConflict;
    }
  }
  {
    // Sequence numbers start at 0 and have no gaps, so "next" is the count; t_ns increases.
    sql::Stmt s(db_,
                "SELECT COUNT(*), COALESCE(MAX(t_ns), -9223372036854775807) FROM keyframes "
                "WHERE session_id = ?");
    s.Bind(1, session_id);
    s.Step();
    if (k.seq != s.Int(0)) return PutKeyframeOutcome::kOutOfOrder;
    if (s.Int(0) > 0 && k.t_ns <= s.Int(1)) return PutKeyframeOutcome::kTimeNotIncreasing;
  }
  sql::Stmt s(db_,
              "INSERT INTO keyframes (session_id, seq, t_ns, pose_json, covariance, depth_png, "
              "content_sha, cloud, cloud_params) VALUES (?,?,?,?,?,?,?,?,?)");
  s.Bind(1, session_id).Bind(2, k.seq).Bind(3, k.t_ns).Bind(4, k.pose_json)
      .Bind(5, k.covariance_json).Bind(6, k.depth_png).Bind(7, k.content_sha);
  if (k.cloud.empty()) s.BindNull(8).BindNull(9);
  else s.Bind(8, k.cloud).Bind(9, k.cloud_params);
  s.Run();
  tx.Commit();  // synchronous=FULL: on disk before we acknowledge
  return PutKeyframeOutcome::kStored;
}

void SqliteStorage::ForEachKeyframe(int64_t session_id, int64_t first_seq, int64_t end_seq,
                                    bool with_depth,
                                    const std::function<void(const KeyframeRecord&)>& fn) {
  // Read one keyframe per lock so that uploads of other sessions are not blocked for long.
  const std::string sql = std::string("SELECT seq, t_ns, pose_json, covariance, ") +
                          (with_depth ? "depth_png" : "NULL") +
                          ", content_sha, cloud, cloud_params FROM keyframes "
                          "WHERE session_id = ? AND seq >= ? AND seq < ? ORDER BY seq LIMIT 1";
  int64_t next_seq = first_seq;
  while (next_seq < end_seq) {
    KeyframeRecord k;
    {
      std::lock_guard lock(mutex_);
      sql::Stmt s(db_, sql);
      s.Bind(1, session_id).Bind(2, next_seq).Bind(3, end_seq);
      if (!s.Step()) return;
      k.seq = s.Int(0);
      k.t_ns = s.Int(1);
      k.pose_json = s.Text(2);
      k.covariance_json = s.OptText(3);
      k.depth_png = s.Blob(4);
      k.content_sha = s.Text(5);
      k.cloud = s.Blob(6);
      k.cloud_params = s.OptText(7).value_or("");
    }
    next_seq = k.seq + 1;
    fn(k);
  }
}

std::optional<int64_t> SqliteStorage::CommitSession(int64_t session_id,
                                                    const std::string& params_json,
                                                    int64_t now_ms) {
  std::lock_guard lock(mutex_);
  sql::Transaction tx(db_);
  sql::Stmt u(db_, "UPDATE sessions SET state = 'committing' WHERE id = ? AND state = 'open'");
  u.Bind(1, session_id).Run();
  if (db_.Changes() == 0) return std::nullopt;
  sql::Stmt j(db_,
              "INSERT INTO jobs (type, state, params_json, created_ms) VALUES ('commit','queued',?,?)");
  j.Bind(1, params_json).Bind(2, now_ms).Run();
  const int64_t job_id = db_.LastInsertId();
  sql::Stmt l(db_, "UPDATE sessions SET job_id = ? WHERE id = ?");
  l.Bind(1, job_id).Bind(2, session_id).Run();
  tx.Commit();
  return job_id;
}

void SqliteStorage::FinishSession(int64_t session_id, const std::string& state,
                                  const std::optional<std::string>& registration_json,
                                  int64_t now_ms) {
  std::lock_guard lock(mutex_);
  sql::Transaction tx(db_);
  sql::Stmt s(db_,
              "UPDATE sessions SET state = ?, registration_json = COALESCE(?, registration_json), "
              "committed_ms = ? WHERE id = ?");
  s.Bind(1, state).Bind(2, registration_json).Bind(3, now_ms).Bind(4, session_id).Run();
  if (state == "committed") {
    // The upload-time clouds only speed up the commit; once it is done they are dead weight
    // (as large as the PNGs). A commit resumed after this point recomputes them.
    sql::Stmt c(db_, "UPDATE keyframes SET cloud = NULL, cloud_params = NULL WHERE session_id = ?");
    c.Bind(1, session_id).Run();
  }
  tx.Commit();
}

void SqliteStorage::PutSessionObserved(int64_t session_id, const Bytes& observed) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, "INSERT OR REPLACE INTO session_observed (session_id, observed) VALUES (?,?)");
  s.Bind(1, session_id).Bind(2, observed).Run();
}

std::optional<Bytes> SqliteStorage::GetSessionObserved(int64_t session_id) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, "SELECT observed FROM session_observed WHERE session_id = ?");
  s.Bind(1, session_id);
  if (!s.Step()) return std::nullopt;
  return s.Blob(0);
}

std::optional<std::string> SqliteStorage::GetSetting(const std::string& key) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, "SELECT value FROM settings WHERE key = ?");
  s.Bind(1, key);
  if (!s.Step()) return std::nullopt;
  return s.Text(0);
}

void SqliteStorage::PutSetting(const std::string& key, const std::string& value) {
  std::lock_guard lock(mutex_);
  sql::Stmt s(db_, "INSERT OR REPLACE INTO settings (key, value) VALUES (?,?)");
  s.Bind(1, key).Bind(2, value).Run();
}

}  // namespace mapdelta::server
