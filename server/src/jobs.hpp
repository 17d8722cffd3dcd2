#pragma once
// Background jobs (commit, refresh, reclassify). Each runs in the job worker thread, writes
// each tile in its own transaction, records finished tiles in job_tiles, and on resume after
// a crash skips what is done and recomputes the rest (every step is a pure function of the
// stored inputs, so recomputation gives the same answer).
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>

#include "mapdelta/server/config.hpp"
#include "mapdelta/server/map_service.hpp"
#include "mapdelta/server/metrics.hpp"
#include "mapdelta/server/storage.hpp"

namespace mapdelta::server {

// Thrown by JobContext::CheckStop: the job stops between tiles, leaving only whole tiles.
struct JobInterrupted : std::runtime_error {
  explicit JobInterrupted(bool cancelled)
      : std::runtime_error(cancelled ? "cancelled" : "server shutting down"),
        cancelled(cancelled) {}
  bool cancelled;
};

// Thrown by JobContext::WaitForEarlierJobs when an earlier job has no worker (queued, or its
// worker died): this worker hands its job back to the queue and takes the earlier one first.
struct JobYield : std::runtime_error {
  explicit JobYield(int64_t earlier_id)
      : std::runtime_error("job " + std::to_string(earlier_id) + " must run first") {}
};

struct JobContext {
  Storage& storage;
  const ServerConfig& config;
  Metrics& metrics;
  JobRecord job;
  std::function<bool()> shutting_down;  // true on shutdown, or when this worker lost the lease

  void Progress(double fraction, const std::string& message);
  void CheckStop();  // throws JobInterrupted on shutdown or cancel request
  void
  CheckShutdown();  // throws JobInterrupted(false) on shutdown only (past the point of no cancel)
  // Jobs write tiles in job-id order, whatever the number of workers, so the result is the
  // one-worker result: waits until every earlier job (or, with of_type, every earlier job of
  // that type) has finished. Throws JobYield if that job has no worker, JobInterrupted on
  // shutdown.
  void WaitForEarlierJobs(std::optional<JobType> of_type = std::nullopt);
};

// Current classification parameters (settings table, else the config's).
ClassifyConfig CurrentClassifyConfig(Storage& storage, const ClassifyConfig& fallback);
Json ToJson(const ClassifyConfig& c);
// Throws ApiError(kInvalidArgument) naming the bad field.
ClassifyConfig ClassifyConfigFromJson(const Json& j, const ClassifyConfig& base);

Json RunCommitJob(JobContext& ctx);   // returns the result JSON
Json RunRefreshJob(JobContext& ctx);  // finishes the job itself (atomically with the version)
Json RunReclassifyJob(JobContext& ctx);
Json RunRollbackJob(JobContext& ctx);  // rollback_job.cpp
// A rollback request's params {"version", "cause"?}, checked against the latest version:
// throws ApiError(kInvalidArgument) for other fields or a bad cause, kNotFound for a version
// that does not exist or the latest itself (already current: nothing to roll back).
Json RollbackJobParams(const Json& body, int64_t latest);

}  // namespace mapdelta::server
