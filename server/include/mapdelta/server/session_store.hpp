#pragma once
// Upload sessions, their keyframes, and each session's observed octree.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "mapdelta/server/states.hpp"
#include "mapdelta/server/storage_types.hpp"

namespace mapdelta::server {

struct SessionRecord {
  int64_t id = 0;
  std::string vehicle_id, camera_json;
  SessionState state = SessionState::kOpen;
  double depth_scale = 1000.0;
  int64_t created_ms = 0;
  std::optional<int64_t> committed_ms, job_id;
  std::optional<std::string> registration_json;
  // How much its evidence about changes counts (localization_quality.hpp), set by its commit.
  std::optional<double> localization_weight;
  std::optional<std::string> localization_json;
  int64_t keyframe_count = 0;  // derived on read
  int64_t last_t_ns = 0;       // derived on read: greatest keyframe t_ns, 0 without keyframes
};

struct KeyframeRecord {
  int64_t seq = 0, t_ns = 0;
  std::string pose_json;
  std::optional<std::string> covariance_json;
  Bytes depth_png;
  std::string content_sha;
  // Derived at upload (empty = not computed): the keyframe's back-projected, voxel-filtered
  // cloud (EncodePoints) and the pipeline parameters it was computed with.
  Bytes cloud;
  std::string cloud_params;
};

// What PutKeyframe did, in the order it checks: no session; a session that is no longer open
// (a repeat of a stored keyframe is still kIdentical); same seq with the same / other
// content_sha; seq not the next one (seqs start at 0, no gaps); t_ns not above the last one.
enum class PutKeyframeOutcome {
  kStored,
  kIdentical,
  kConflict,
  kOutOfOrder,
  kTimeNotIncreasing,
  kSessionNotOpen,
  kNoSession
};

class SessionStore {
 public:
  virtual ~SessionStore() = default;
  // Stores a new open session (id, state, job and derived fields of the record are ignored).
  virtual int64_t Create(const SessionRecord& session) = 0;
  virtual std::optional<SessionRecord> Get(int64_t id) = 0;
  // Durable when it returns kStored (a 201 is acknowledged on it).
  virtual PutKeyframeOutcome PutKeyframe(int64_t session_id, const KeyframeRecord& keyframe) = 0;
  // Keyframes with first_seq <= seq < end_seq in seq order, one at a time (a session's depth
  // images may not fit in memory). with_depth = false leaves depth_png empty (a commit's first
  // pass reads only the stored clouds). Safe to call from several threads at once.
  virtual void ForEachKeyframe(int64_t session_id, int64_t first_seq, int64_t end_seq,
                               bool with_depth,
                               const std::function<void(const KeyframeRecord&)>& fn) = 0;
  // Moves an open session to committing and queues its commit job (params_json), atomically;
  // the session records the job. Returns the job id, or nullopt if the session is not open.
  virtual std::optional<int64_t> Commit(int64_t session_id, const std::string& params_json,
                                        int64_t now_ms) = 0;
  // Sets the session's state and committed_ms (= now_ms); registration_json replaces the
  // stored one unless nullopt. kCommitted also drops the keyframes' upload-time clouds.
  virtual void Finish(int64_t session_id, SessionState state,
                      const std::optional<std::string>& registration_json, int64_t now_ms) = 0;
  // Sets the session's localization weight in [0, 1] and its report (JSON text). Throws
  // Error(kConflict) for an unknown session.
  virtual void PutLocalization(int64_t session_id, double weight, const std::string& json) = 0;
  // Replaces the session's observed octree. Throws Error(kConflict) for an unknown session.
  virtual void PutObserved(int64_t session_id, const Bytes& observed) = 0;
  virtual std::optional<Bytes> GetObserved(int64_t session_id) = 0;
};

}  // namespace mapdelta::server
