// SQLite session store: sessions, keyframes, observed octrees.
#include "storage_sqlite.hpp"

namespace mapdelta::server {

int64_t SqliteSessionStore::Create(const SessionRecord& r) {
  auto lock = Lock();
  sql::Stmt s(db(),
              "INSERT INTO sessions (vehicle_id, camera_json, depth_scale, state, created_ms) "
              "VALUES (?,?,?,?,?)");
  s.Bind(1, r.vehicle_id)
      .Bind(2, r.camera_json)
      .Bind(3, r.depth_scale)
      .Bind(4, ToString(SessionState::kOpen))
      .Bind(5, r.created_ms);
  s.Run();
  return db().LastInsertId();
}

std::optional<SessionRecord> SqliteSessionStore::Get(int64_t id) {
  auto lock = Lock();
  sql::Stmt s(db(),
              "SELECT id, vehicle_id, camera_json, depth_scale, state, created_ms, committed_ms, "
              "job_id, registration_json, (SELECT COUNT(*) FROM keyframes WHERE session_id = id), "
              "(SELECT COALESCE(MAX(t_ns), 0) FROM keyframes WHERE session_id = id), "
              "localization_weight, localization_json FROM sessions WHERE id = ?");
  s.Bind(1, id);
  if (!s.Step()) return std::nullopt;
  SessionRecord r;
  r.id = s.Int(0);
  r.vehicle_id = s.Text(1);
  r.camera_json = s.Text(2);
  r.depth_scale = s.Real(3);
  r.state = ParseEnumOrThrow<SessionState>(s.Text(4), "sessions.state");
  r.created_ms = s.Int(5);
  if (!s.IsNull(6)) r.committed_ms = s.Int(6);
  if (!s.IsNull(7)) r.job_id = s.Int(7);
  r.registration_json = s.OptText(8);
  r.keyframe_count = s.Int(9);
  r.last_t_ns = s.Int(10);
  if (!s.IsNull(11)) r.localization_weight = s.Real(11);
  r.localization_json = s.OptText(12);
  return r;
}

PutKeyframeOutcome SqliteSessionStore::PutKeyframe(int64_t session_id, const KeyframeRecord& k) {
  auto lock = Lock();
  sql::Transaction tx(db());
  {
    sql::Stmt s(db(), "SELECT state FROM sessions WHERE id = ?");
    s.Bind(1, session_id);
    if (!s.Step()) return PutKeyframeOutcome::kNoSession;
    if (ParseEnumOrThrow<SessionState>(s.Text(0), "sessions.state") != SessionState::kOpen) {
      // A retry of an already-stored keyframe after commit is still a harmless repeat.
      sql::Stmt e(db(), "SELECT content_sha FROM keyframes WHERE session_id = ? AND seq = ?");
      e.Bind(1, session_id).Bind(2, k.seq);
      if (e.Step() && e.Text(0) == k.content_sha) return PutKeyframeOutcome::kIdentical;
      return PutKeyframeOutcome::kSessionNotOpen;
    }
  }
  {
    sql::Stmt s(db(), "SELECT content_sha FROM keyframes WHERE session_id = ? AND seq = ?");
    s.Bind(1, session_id).Bind(2, k.seq);
    if (s.Step()) {
      return s.Text(0) == k.content_sha ? PutKeyframeOutcome::kIdentical
                                        : PutKeyframeOutcome::kConflict;
    }
  }
  {
    // Sequence numbers start at 0 and have no gaps, so "next" is the count; t_ns increases.
    sql::Stmt s(db(),
                "SELECT COUNT(*), COALESCE(MAX(t_ns), -9223372036854775807) FROM keyframes "
                "WHERE session_id = ?");
    s.Bind(1, session_id);
    s.Step();
    if (k.seq != s.Int(0)) return PutKeyframeOutcome::kOutOfOrder;
    if (s.Int(0) > 0 && k.t_ns <= s.Int(1)) return PutKeyframeOutcome::kTimeNotIncreasing;
  }
  sql::Stmt s(db(),
              "INSERT INTO keyframes (session_id, seq, t_ns, pose_json, covariance, depth_png, "
              "content_sha, cloud, cloud_params) VALUES (?,?,?,?,?,?,?,?,?)");
  s.Bind(1, session_id)
      .Bind(2, k.seq)
      .Bind(3, k.t_ns)
      .Bind(4, k.pose_json)
      .Bind(5, k.covariance_json)
      .Bind(6, k.depth_png)
      .Bind(7, k.content_sha);
  if (k.cloud.empty())
    s.BindNull(8).BindNull(9);
  else
    s.Bind(8, k.cloud).Bind(9, k.cloud_params);
  s.Run();
  tx.Commit();  // synchronous=FULL: on disk before we acknowledge
  return PutKeyframeOutcome::kStored;
}

void SqliteSessionStore::ForEachKeyframe(int64_t session_id, int64_t first_seq, int64_t end_seq,
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
      auto lock = Lock();
      sql::Stmt s(db(), sql);
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

std::optional<int64_t> SqliteSessionStore::Commit(int64_t session_id,
                                                  const std::string& params_json, int64_t now_ms) {
  auto lock = Lock();
  sql::Transaction tx(db());
  sql::Stmt u(db(), "UPDATE sessions SET state = ? WHERE id = ? AND state = ?");
  u.Bind(1, ToString(SessionState::kCommitting))
      .Bind(2, session_id)
      .Bind(3, ToString(SessionState::kOpen))
      .Run();
  if (db().Changes() == 0) return std::nullopt;
  sql::Stmt j(db(), "INSERT INTO jobs (type, state, params_json, created_ms) VALUES (?,?,?,?)");
  j.Bind(1, ToString(JobType::kCommit))
      .Bind(2, ToString(JobState::kQueued))
      .Bind(3, params_json)
      .Bind(4, now_ms)
      .Run();
  const int64_t job_id = db().LastInsertId();
  sql::Stmt l(db(), "UPDATE sessions SET job_id = ? WHERE id = ?");
  l.Bind(1, job_id).Bind(2, session_id).Run();
  tx.Commit();
  return job_id;
}

void SqliteSessionStore::Finish(int64_t session_id, SessionState state,
                                const std::optional<std::string>& registration_json,
                                int64_t now_ms) {
  auto lock = Lock();
  sql::Transaction tx(db());
  sql::Stmt s(db(),
              "UPDATE sessions SET state = ?, registration_json = COALESCE(?, registration_json), "
              "committed_ms = ? WHERE id = ?");
  s.Bind(1, ToString(state)).Bind(2, registration_json).Bind(3, now_ms).Bind(4, session_id).Run();
  if (state == SessionState::kCommitted) {
    // The upload-time clouds only speed up the commit; once it is done they are dead weight
    // (as large as the PNGs). A commit resumed after this point recomputes them.
    sql::Stmt c(db(),
                "UPDATE keyframes SET cloud = NULL, cloud_params = NULL WHERE session_id = ?");
    c.Bind(1, session_id).Run();
  }
  tx.Commit();
}

void SqliteSessionStore::PutLocalization(int64_t session_id, double weight,
                                         const std::string& json) {
  auto lock = Lock();
  sql::Stmt s(db(),
              "UPDATE sessions SET localization_weight = ?, localization_json = ? WHERE id = ?");
  s.Bind(1, weight).Bind(2, json).Bind(3, session_id).Run();
  if (db().Changes() == 0) {
    throw Error(ErrorCode::kConflict,
                "localization for unknown session " + std::to_string(session_id));
  }
}

void SqliteSessionStore::PutObserved(int64_t session_id, const Bytes& observed) {
  auto lock = Lock();
  sql::Stmt s(db(), "INSERT OR REPLACE INTO session_observed (session_id, observed) VALUES (?,?)");
  s.Bind(1, session_id).Bind(2, observed).Run();
}

std::optional<Bytes> SqliteSessionStore::GetObserved(int64_t session_id) {
  auto lock = Lock();
  sql::Stmt s(db(), "SELECT observed FROM session_observed WHERE session_id = ?");
  s.Bind(1, session_id);
  if (!s.Step()) return std::nullopt;
  return s.Blob(0);
}

}  // namespace mapdelta::server
