// PostgreSQL session store: sessions, keyframes, observed octrees.
#include "storage_postgres.hpp"

namespace mapdelta::server {
namespace {
// Keyframes read per query by ForEachKeyframe (with depth ~15 KB each at 800x450).
constexpr int kKeyframeBatch = 16;
}  // namespace

int64_t PostgresSessionStore::Create(const SessionRecord& s) {
  auto c = Connect();
  return c
      ->Query(
          "INSERT INTO sessions (vehicle_id, camera_json, depth_scale, "
          "state, created_ms) "
          "VALUES ($1,$2,$3,$4,$5) RETURNING id",
          pg::Params()
              .Add(s.vehicle_id)
              .Add(s.camera_json)
              .Add(s.depth_scale)
              .Add(ToString(SessionState::kOpen))
              .Add(s.created_ms))
      .Int(0, 0);
}

std::optional<SessionRecord> PostgresSessionStore::Get(int64_t id) {
  auto c = Connect();
  const pg::Result r = c->Query(
      "SELECT s.id, vehicle_id, camera_json, "
      "depth_scale, state, created_ms, committed_ms, "
      "job_id, registration_json, (SELECT COUNT(*) "
      "FROM keyframes k WHERE k.session_id = s.id), "
      "(SELECT COALESCE(MAX(t_ns), 0) FROM keyframes "
      "k WHERE k.session_id = s.id), localization_weight, localization_json "
      "FROM sessions s WHERE s.id = $1",
      pg::Params().Add(id));
  if (r.rows() == 0) return std::nullopt;
  SessionRecord s;
  s.id = r.Int(0, 0);
  s.vehicle_id = r.Text(0, 1);
  s.camera_json = r.Text(0, 2);
  s.depth_scale = r.Real(0, 3);
  s.state = ParseEnumOrThrow<SessionState>(r.Text(0, 4), "sessions.state");
  s.created_ms = r.Int(0, 5);
  s.committed_ms = r.OptInt(0, 6);
  s.job_id = r.OptInt(0, 7);
  s.registration_json = r.OptText(0, 8);
  s.keyframe_count = r.Int(0, 9);
  s.last_t_ns = r.Int(0, 10);
  if (!r.IsNull(0, 11)) s.localization_weight = r.Real(0, 11);
  s.localization_json = r.OptText(0, 12);
  return s;
}

PutKeyframeOutcome PostgresSessionStore::PutKeyframe(int64_t session_id, const KeyframeRecord& k) {
  auto c = Connect();
  pg::Transaction tx(*c);
  // The session row's lock orders concurrent uploads to one session (from any process) and keeps a
  // commit from slipping in between the checks and the insert.
  const pg::Result session =
      c->Query("SELECT state FROM sessions WHERE id = $1 FOR UPDATE", pg::Params().Add(session_id));
  if (session.rows() == 0) return PutKeyframeOutcome::kNoSession;
  const pg::Result existing =
      c->Query("SELECT content_sha FROM keyframes WHERE session_id = $1 AND seq = $2",
               pg::Params().Add(session_id).Add(k.seq));
  if (ParseEnumOrThrow<SessionState>(session.Text(0, 0), "sessions.state") != SessionState::kOpen) {
    // A retry of an already-stored keyframe after commit is still a harmless repeat.
    if (existing.rows() > 0 && existing.Text(0, 0) == k.content_sha) {
      return PutKeyframeOutcome::kIdentical;
    }
    return PutKeyframeOutcome::kSessionNotOpen;
  }
  if (existing.rows() > 0) {
    return existing.Text(0, 0) == k.content_sha ? PutKeyframeOutcome::kIdentical
                                                : PutKeyframeOutcome::kConflict;
  }
  // Sequence numbers start at 0 and have no gaps, so "next" is the count; t_ns increases.
  const pg::Result last = c->Query(
      "SELECT COUNT(*), COALESCE(MAX(t_ns), "
      "-9223372036854775807) FROM keyframes "
      "WHERE session_id = $1",
      pg::Params().Add(session_id));
  if (k.seq != last.Int(0, 0)) return PutKeyframeOutcome::kOutOfOrder;
  if (last.Int(0, 0) > 0 && k.t_ns <= last.Int(0, 1)) {
    return PutKeyframeOutcome::kTimeNotIncreasing;
  }
  pg::Params p;
  p.Add(session_id).Add(k.seq).Add(k.t_ns).Add(k.pose_json).Add(k.covariance_json);
  p.Add(k.depth_png).Add(k.content_sha);
  if (k.cloud.empty()) {
    p.AddNull().AddNull();
  } else {
    p.Add(k.cloud).Add(k.cloud_params);
  }
  c->Query(
      "INSERT INTO keyframes (session_id, seq, t_ns, pose_json, covariance, "
      "depth_png, "
      "content_sha, cloud, cloud_params) VALUES ($1,$2,$3,$4,$5,$6,$7,$8,$9)",
      p);
  tx.Commit();  // synchronous_commit on (PostgreSQL's default): durable before
                // we acknowledge
  return PutKeyframeOutcome::kStored;
}

void PostgresSessionStore::ForEachKeyframe(int64_t session_id, int64_t first_seq, int64_t end_seq,
                                           bool with_depth,
                                           const std::function<void(const KeyframeRecord&)>& fn) {
  // In batches, the connection handed back before the callbacks run: a commit's passes call this
  // from several threads and must not each hold a connection while they compute.
  const std::string sql = std::string("SELECT seq, t_ns, pose_json, covariance, ") +
                          (with_depth ? "depth_png" : "NULL::bytea") +
                          ", content_sha, cloud, cloud_params FROM keyframes "
                          "WHERE session_id = $1 AND seq >= $2 AND seq < $3 ORDER BY seq LIMIT " +
                          std::to_string(kKeyframeBatch);
  int64_t next_seq = first_seq;
  while (next_seq < end_seq) {
    std::vector<KeyframeRecord> batch;
    {
      auto c = Connect();
      const pg::Result r = c->Query(sql, pg::Params().Add(session_id).Add(next_seq).Add(end_seq));
      for (int i = 0; i < r.rows(); ++i) {
        KeyframeRecord k;
        k.seq = r.Int(i, 0);
        k.t_ns = r.Int(i, 1);
        k.pose_json = r.Text(i, 2);
        k.covariance_json = r.OptText(i, 3);
        k.depth_png = r.Bytes(i, 4);
        k.content_sha = r.Text(i, 5);
        k.cloud = r.Bytes(i, 6);
        k.cloud_params = r.OptText(i, 7).value_or("");
        batch.push_back(std::move(k));
      }
    }
    if (batch.empty()) return;
    next_seq = batch.back().seq + 1;
    for (const KeyframeRecord& k : batch) fn(k);
  }
}

std::optional<int64_t> PostgresSessionStore::Commit(int64_t session_id,
                                                    const std::string& params_json,
                                                    int64_t now_ms) {
  auto c = Connect();
  pg::Transaction tx(*c);
  if (c->Query("UPDATE sessions SET state = $1 WHERE id = $2 AND state = $3",
               pg::Params()
                   .Add(ToString(SessionState::kCommitting))
                   .Add(session_id)
                   .Add(ToString(SessionState::kOpen)))
          .affected() == 0) {
    return std::nullopt;
  }
  const int64_t job_id = c->Query(
                              "INSERT INTO jobs (type, state, params_json, created_ms) "
                              "VALUES ($1,$2,$3,$4) RETURNING id",
                              pg::Params()
                                  .Add(ToString(JobType::kCommit))
                                  .Add(ToString(JobState::kQueued))
                                  .Add(params_json)
                                  .Add(now_ms))
                             .Int(0, 0);
  c->Query("UPDATE sessions SET job_id = $1 WHERE id = $2",
           pg::Params().Add(job_id).Add(session_id));
  tx.Commit();
  return job_id;
}

void PostgresSessionStore::Finish(int64_t session_id, SessionState state,
                                  const std::optional<std::string>& registration_json,
                                  int64_t now_ms) {
  auto c = Connect();
  pg::Transaction tx(*c);
  c->Query(
      "UPDATE sessions SET state = $1, registration_json = COALESCE($2, "
      "registration_json), "
      "committed_ms = $3 WHERE id = $4",
      pg::Params().Add(ToString(state)).Add(registration_json).Add(now_ms).Add(session_id));
  if (state == SessionState::kCommitted) {
    // As in SQLite: the upload-time clouds only speed up the commit; drop them once done.
    c->Query(
        "UPDATE keyframes SET cloud = NULL, cloud_params = NULL WHERE "
        "session_id = $1",
        pg::Params().Add(session_id));
  }
  tx.Commit();
}

void PostgresSessionStore::PutLocalization(int64_t session_id, double weight,
                                           const std::string& json) {
  auto c = Connect();
  const pg::Result r =
      c->Query("UPDATE sessions SET localization_weight = $1, localization_json = $2 WHERE id = $3",
               pg::Params().Add(weight).Add(json).Add(session_id));
  if (r.affected() == 0) {
    throw Error(ErrorCode::kConflict,
                "localization for unknown session " + std::to_string(session_id));
  }
}

void PostgresSessionStore::PutObserved(int64_t session_id, const Bytes& observed) {
  auto c = Connect();
  c->Query(
      "INSERT INTO session_observed (session_id, observed) VALUES ($1,$2) "
      "ON CONFLICT (session_id) DO UPDATE SET observed = EXCLUDED.observed",
      pg::Params().Add(session_id).Add(observed));
}

std::optional<Bytes> PostgresSessionStore::GetObserved(int64_t session_id) {
  auto c = Connect();
  const pg::Result r = c->Query("SELECT observed FROM session_observed WHERE session_id = $1",
                                pg::Params().Add(session_id));
  if (r.rows() == 0) return std::nullopt;
  return r.Bytes(0, 0);
}

}  // namespace mapdelta::server
