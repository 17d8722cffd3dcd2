#pragma once
// The job queue (commit, refresh, reclassify) and the tiles each job has applied.
#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "mapdelta/server/states.hpp"
#include "mapdelta/server/tile_store.hpp"  // TileChangesRecord, staged by CompleteTileWork

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
  // The worker running it (JobStore::worker_id() of its process) and until when, while
  // running; a running job whose lease ran out has lost its worker.
  std::optional<std::string> lease_owner;
  std::optional<int64_t> lease_expires_ms;
};

// An unfinished job before another (JobStore::UnfinishedBefore).
struct EarlierJob {
  int64_t id = 0;
  bool claimable = false;  // queued, or running with its lease run out: no worker has it
};

// One tile of a commit job's classification as a work item (issue #19): any worker may claim
// it, so several workers classify different tiles of one commit at the same time. An item is
// unclaimed (no lease_owner, not done), claimed (lease_owner until lease_expires_ms), done
// (its result staged under done_by, not yet visible to readers) or published (the results of
// all the job's items went to the tiles at once: TileStore::PublishTileWork).
struct TileWorkItem {
  int64_t job_id = 0;
  TileId tile;
  int64_t prior_version = 0;  // the prior the job classifies against
  // The fencing token: every claim increments it, and only the holder of the latest claim may
  // complete the item (a worker that stalled past its lease writes nothing).
  int64_t claims = 0;
  std::optional<std::string> lease_owner;
  std::optional<int64_t> lease_expires_ms;
  std::optional<std::string> done_by;        // the worker whose result is staged
  int64_t new_count = 0, removed_count = 0;  // of the staged result
  bool published = false;
};

// A new lease owner id for this process: "host:pid:random".
std::string NewWorkerId();

class JobStore {
 public:
  virtual ~JobStore() = default;
  virtual int64_t Create(JobType type, const std::string& params_json, int64_t now_ms) = 0;
  virtual std::optional<JobRecord> Get(int64_t id) = 0;
  virtual std::vector<JobRecord> List(int64_t limit, int64_t offset) = 0;  // newest first
  // Claims the oldest job that is queued, or running with its lease run out (its worker died
  // or stalled): running, attempts + 1, started_ms set on the first claim, leased to
  // worker_id() until now_ms + lease_ms. Several processes may claim at once on a shared
  // backend; each job goes to one of them.
  virtual std::optional<JobRecord> ClaimNext(int64_t now_ms, int64_t lease_ms) = 0;
  // Extends this worker's lease to now_ms + lease_ms; false if the job is no longer running
  // under it (finished, released, or taken over by another worker).
  virtual bool RenewLease(int64_t id, int64_t now_ms, int64_t lease_ms) = 0;
  // Hands this worker's running job back to the queue (it resumes from what is stored).
  virtual void Release(int64_t id) = 0;
  // The oldest unfinished (queued or running) job with an id below job_id (and of type, if
  // given), and whether a worker could claim it at now_ms.
  virtual std::optional<EarlierJob> UnfinishedBefore(int64_t job_id, int64_t now_ms,
                                                     std::optional<JobType> type) = 0;
  // This store's lease owner id: host, pid and a random part.
  virtual const std::string& worker_id() const = 0;
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
  // A backend one process owns (SQLite, memory) takes every running job; a shared one
  // (PostgreSQL) only those whose lease ran out at now_ms, as live workers hold the others.
  virtual int RequeueInterrupted(int64_t now_ms) = 0;
  // Tiles the job recorded as applied (TileStore::ApplyUpdates / ApplyChanges).
  virtual std::set<std::string> TilesDone(int64_t job_id) = 0;
  // Per-tile work of a commit job (TileWorkItem). Adds an unclaimed item per tile, classified
  // against prior_version; tiles the job already lists keep their item as it is (a resumed job
  // does not redo what is done).
  virtual void AddTileWork(int64_t job_id, int64_t prior_version,
                           const std::vector<TileId>& tiles) = 0;
  // Claims one item that is not done, of a running job (of job_id if given, else of the oldest
  // job with work): unclaimed, or claimed under a lease that ran out at now_ms (its worker died
  // or stalled). claims + 1, leased to worker_id() until now_ms + lease_ms; the lowest tile
  // (ix, iy) first. Several processes may claim at once on a shared backend; each claim goes
  // to one of them and never waits for another's.
  virtual std::optional<TileWorkItem> ClaimTileWork(std::optional<int64_t> job_id, int64_t now_ms,
                                                    int64_t lease_ms) = 0;
  // Stages result (the tile's classification; result.tile is the item's) and marks the item
  // done by worker_id(), if it is still claimed by this worker under claimed.claims; returns
  // false, writing nothing, if it is not (taken over after its lease, or done already).
  virtual bool CompleteTileWork(const TileWorkItem& claimed, const TileChangesRecord& result) = 0;
  // The job's items, ordered by tile (ix, iy).
  virtual std::vector<TileWorkItem> ListTileWork(int64_t job_id) = 0;
  // Only states with at least one job, in no particular order.
  virtual std::vector<std::pair<JobState, int64_t>> CountByState() = 0;
};

}  // namespace mapdelta::server
