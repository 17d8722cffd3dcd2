// In-memory session store: sessions, keyframes, observed octrees.
#include <algorithm>

#include "mapdelta/common/error.hpp"
#include "storage_memory.hpp"

namespace mapdelta::server {

namespace {
// Greatest t_ns of the keyframes (nullopt without any).
std::optional<int64_t> LastTimeNs(const std::map<int64_t, KeyframeRecord>& keyframes) {
  std::optional<int64_t> last;
  for (const auto& [seq, k] : keyframes) last = std::max(last.value_or(k.t_ns), k.t_ns);
  return last;
}
}  // namespace

int64_t MemorySessionStore::Create(const SessionRecord& session) {
  auto lock = Lock();
  MemoryTables::SessionRow row;
  row.record.id = NextId(t().sessions);
  row.record.vehicle_id = session.vehicle_id;
  row.record.camera_json = session.camera_json;
  row.record.depth_scale = session.depth_scale;
  row.record.state = SessionState::kOpen;
  row.record.created_ms = session.created_ms;
  const int64_t id = row.record.id;
  t().sessions[id] = std::move(row);
  return id;
}

std::optional<SessionRecord> MemorySessionStore::Get(int64_t id) {
  auto lock = Lock();
  auto it = t().sessions.find(id);
  if (it == t().sessions.end()) return std::nullopt;
  SessionRecord r = it->second.record;
  r.keyframe_count = static_cast<int64_t>(it->second.keyframes.size());
  r.last_t_ns = LastTimeNs(it->second.keyframes).value_or(0);
  return r;
}

PutKeyframeOutcome MemorySessionStore::PutKeyframe(int64_t session_id, const KeyframeRecord& k) {
  auto lock = Lock();
  auto it = t().sessions.find(session_id);
  if (it == t().sessions.end()) return PutKeyframeOutcome::kNoSession;
  auto& keyframes = it->second.keyframes;
  auto existing = keyframes.find(k.seq);
  if (it->second.record.state != SessionState::kOpen) {
    // A retry of an already-stored keyframe after commit is still a harmless repeat.
    if (existing != keyframes.end() && existing->second.content_sha == k.content_sha) {
      return PutKeyframeOutcome::kIdentical;
    }
    return PutKeyframeOutcome::kSessionNotOpen;
  }
  if (existing != keyframes.end()) {
    return existing->second.content_sha == k.content_sha ? PutKeyframeOutcome::kIdentical
                                                         : PutKeyframeOutcome::kConflict;
  }
  // Sequence numbers start at 0 and have no gaps, so "next" is the count; t_ns increases.
  if (k.seq != static_cast<int64_t>(keyframes.size())) return PutKeyframeOutcome::kOutOfOrder;
  const std::optional<int64_t> last = LastTimeNs(keyframes);
  if (last && k.t_ns <= *last) return PutKeyframeOutcome::kTimeNotIncreasing;
  KeyframeRecord stored = k;
  if (stored.cloud.empty()) stored.cloud_params.clear();  // a cloud's parameters or none
  keyframes[k.seq] = std::move(stored);
  return PutKeyframeOutcome::kStored;
}

void MemorySessionStore::ForEachKeyframe(int64_t session_id, int64_t first_seq, int64_t end_seq,
                                         bool with_depth,
                                         const std::function<void(const KeyframeRecord&)>& fn) {
  // One keyframe per lock, as the SQLite store reads: fn may take long or call back in.
  int64_t next_seq = first_seq;
  while (next_seq < end_seq) {
    KeyframeRecord k;
    {
      auto lock = Lock();
      auto session = t().sessions.find(session_id);
      if (session == t().sessions.end()) return;
      auto it = session->second.keyframes.lower_bound(next_seq);
      if (it == session->second.keyframes.end() || it->first >= end_seq) return;
      k = it->second;
    }
    if (!with_depth) k.depth_png.clear();
    next_seq = k.seq + 1;
    fn(k);
  }
}

std::optional<int64_t> MemorySessionStore::Commit(int64_t session_id,
                                                  const std::string& params_json, int64_t now_ms) {
  auto lock = Lock();
  auto it = t().sessions.find(session_id);
  if (it == t().sessions.end() || it->second.record.state != SessionState::kOpen) {
    return std::nullopt;
  }
  const int64_t job_id = InsertQueuedJob(t(), JobType::kCommit, params_json, now_ms);
  it->second.record.state = SessionState::kCommitting;
  it->second.record.job_id = job_id;
  return job_id;
}

void MemorySessionStore::Finish(int64_t session_id, SessionState state,
                                const std::optional<std::string>& registration_json,
                                int64_t now_ms) {
  auto lock = Lock();
  auto it = t().sessions.find(session_id);
  if (it == t().sessions.end()) return;
  SessionRecord& r = it->second.record;
  r.state = state;
  if (registration_json) r.registration_json = registration_json;
  r.committed_ms = now_ms;
  if (state == SessionState::kCommitted) {
    // The upload-time clouds only speed up the commit (see the SQLite store).
    for (auto& [seq, k] : it->second.keyframes) {
      k.cloud.clear();
      k.cloud_params.clear();
    }
  }
}

void MemorySessionStore::PutLocalization(int64_t session_id, double weight,
                                         const std::string& json) {
  auto lock = Lock();
  auto it = t().sessions.find(session_id);
  if (it == t().sessions.end()) {
    throw Error(ErrorCode::kConflict,
                "localization for unknown session " + std::to_string(session_id));
  }
  it->second.record.localization_weight = weight;
  it->second.record.localization_json = json;
}

void MemorySessionStore::PutObserved(int64_t session_id, const Bytes& observed) {
  auto lock = Lock();
  auto it = t().sessions.find(session_id);
  if (it == t().sessions.end()) {
    throw Error(ErrorCode::kConflict,
                "observed octree for unknown session " + std::to_string(session_id));
  }
  it->second.observed = observed;
}

std::optional<Bytes> MemorySessionStore::GetObserved(int64_t session_id) {
  auto lock = Lock();
  auto it = t().sessions.find(session_id);
  if (it == t().sessions.end()) return std::nullopt;
  return it->second.observed;
}

}  // namespace mapdelta::server
