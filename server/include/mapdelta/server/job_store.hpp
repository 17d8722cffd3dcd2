#pragma once
// The job queue (commit, refresh, reclassify) and the tiles each job has applied.
#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "mapdelta/server/states.hpp"

namespace mapdelta::server {

struct JobRecord {
  int64_t id = 0;
  JobType type = JobType::kCommit;
  JobState state = JobState::kQueued;
  std::string params_json, message;
  double progress = 0;
  std::optional<std::string> result_json;
  bool cancel_requested = false;
  int64_t attempts = 0, created_ms = 0;
  std::optional<int64_t> started_ms, finished_ms;
};

class JobStore {
 public:
  virtual ~JobStore() = default;
  virtual int64_t Create(JobType type, const std::string& params_json, int64_t now_ms) = 0;
  virtual std::optional<JobRecord> Get(int64_t id) = 0;
  virtual std::vector<JobRecord> List(int64_t limit, int64_t offset) = 0;  // newest first
  // Claims the oldest queued job: running, attempts + 1, started_ms set on the first claim.
  virtual std::optional<JobRecord> ClaimNext(int64_t now_ms) = 0;
  virtual void UpdateProgress(int64_t id, double progress, const std::string& message) = 0;
  // Sets state, message, result (nullopt clears it) and finished_ms; kSucceeded sets
  // progress to 1.
  virtual void Finish(int64_t id, JobState state, const std::string& message,
                      const std::optional<std::string>& result_json, int64_t now_ms) = 0;
  // A queued job is cancelled at once (a commit's session reopens: the vehicle may commit
  // again); a running one gets cancel_requested. Returns the state after the call, nullopt if
  // there is no such job.
  virtual std::optional<JobState> RequestCancel(int64_t id, int64_t now_ms) = 0;
  virtual bool IsCancelRequested(int64_t id) = 0;
  // At start-up: jobs left running by a crash go back to queued (to resume). Returns how many.
  virtual int RequeueInterrupted() = 0;
  // Tiles the job recorded as applied (TileStore::ApplyUpdates / ApplyChanges).
  virtual std::set<std::string> TilesDone(int64_t job_id) = 0;
  // Only states with at least one job, in no particular order.
  virtual std::vector<std::pair<JobState, int64_t>> CountByState() = 0;
};

}  // namespace mapdelta::server
