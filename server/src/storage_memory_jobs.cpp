// In-memory job store: the job queue and the tiles each job applied.
#include <algorithm>

#include "storage_memory.hpp"

namespace mapdelta::server {

int64_t MemoryJobStore::Create(JobType type, const std::string& params_json, int64_t now_ms) {
  auto lock = Lock();
  return InsertQueuedJob(t(), type, params_json, now_ms);
}

std::optional<JobRecord> MemoryJobStore::Get(int64_t id) {
  auto lock = Lock();
  auto it = t().jobs.find(id);
  if (it == t().jobs.end()) return std::nullopt;
  return it->second;
}

std::vector<JobRecord> MemoryJobStore::List(int64_t limit, int64_t offset) {
  auto lock = Lock();
  std::vector<JobRecord> out;
  int64_t skipped = 0;
  for (auto it = t().jobs.rbegin(); it != t().jobs.rend(); ++it) {
    if (limit >= 0 && static_cast<int64_t>(out.size()) >= limit) break;  // SQL: LIMIT < 0 = all
    if (skipped++ < offset) continue;
    out.push_back(it->second);
  }
  return out;
}

namespace {
// Running, and its worker's lease ran out (or it never had one): no worker has it.
bool LeaseRanOut(const JobRecord& job, int64_t now_ms) {
  return job.state == JobState::kRunning && job.lease_expires_ms.value_or(0) < now_ms;
}
}  // namespace

std::optional<JobRecord> MemoryJobStore::ClaimNext(int64_t now_ms, int64_t lease_ms) {
  auto lock = Lock();
  for (auto& [id, job] : t().jobs) {
    if (job.state != JobState::kQueued && !LeaseRanOut(job, now_ms)) continue;
    job.state = JobState::kRunning;
    job.attempts += 1;
    if (!job.started_ms) job.started_ms = now_ms;
    job.lease_owner = worker_id_;
    job.lease_expires_ms = now_ms + lease_ms;
    return job;
  }
  return std::nullopt;
}

bool MemoryJobStore::RenewLease(int64_t id, int64_t now_ms, int64_t lease_ms) {
  auto lock = Lock();
  auto it = t().jobs.find(id);
  if (it == t().jobs.end() || it->second.state != JobState::kRunning ||
      it->second.lease_owner != worker_id_) {
    return false;
  }
  it->second.lease_expires_ms = now_ms + lease_ms;
  return true;
}

void MemoryJobStore::Release(int64_t id) {
  auto lock = Lock();
  auto it = t().jobs.find(id);
  if (it == t().jobs.end() || it->second.state != JobState::kRunning ||
      it->second.lease_owner != worker_id_) {
    return;
  }
  it->second.state = JobState::kQueued;
  it->second.lease_owner.reset();
  it->second.lease_expires_ms.reset();
}

std::optional<EarlierJob> MemoryJobStore::UnfinishedBefore(int64_t job_id, int64_t now_ms,
                                                           std::optional<JobType> type) {
  auto lock = Lock();
  for (const auto& [id, job] : t().jobs) {
    if (id >= job_id) break;
    if (job.state != JobState::kQueued && job.state != JobState::kRunning) continue;
    if (type && job.type != *type) continue;
    return EarlierJob{id, job.state == JobState::kQueued || LeaseRanOut(job, now_ms)};
  }
  return std::nullopt;
}

void MemoryJobStore::UpdateProgress(int64_t id, double progress, const std::string& message) {
  auto lock = Lock();
  auto it = t().jobs.find(id);
  if (it == t().jobs.end()) return;
  it->second.progress = progress;
  it->second.message = message;
}

void MemoryJobStore::Finish(int64_t id, JobState state, const std::string& message,
                            const std::optional<std::string>& result_json, int64_t now_ms) {
  auto lock = Lock();
  auto it = t().jobs.find(id);
  if (it == t().jobs.end()) return;
  JobRecord& job = it->second;
  job.state = state;
  job.message = message;
  job.result_json = result_json;
  job.finished_ms = now_ms;
  job.lease_owner.reset();
  job.lease_expires_ms.reset();
  if (state == JobState::kSucceeded) job.progress = 1.0;
}

std::optional<JobState> MemoryJobStore::RequestCancel(int64_t id, int64_t now_ms) {
  auto lock = Lock();
  auto it = t().jobs.find(id);
  if (it == t().jobs.end()) return std::nullopt;
  JobRecord& job = it->second;
  if (job.state == JobState::kQueued) {
    job.state = JobState::kCancelled;
    job.cancel_requested = true;
    job.finished_ms = now_ms;
    job.message = "cancelled before it started";
    // A cancelled commit leaves its session open so that the vehicle can commit again.
    for (auto& [session_id, row] : t().sessions) {
      if (row.record.job_id != id) continue;
      row.record.state = SessionState::kOpen;
      row.record.job_id.reset();
    }
  } else if (job.state == JobState::kRunning) {
    job.cancel_requested = true;
  }
  return job.state;
}

bool MemoryJobStore::IsCancelRequested(int64_t id) {
  auto lock = Lock();
  auto it = t().jobs.find(id);
  return it != t().jobs.end() && it->second.cancel_requested;
}

int MemoryJobStore::RequeueInterrupted(int64_t /*now_ms*/) {
  auto lock = Lock();
  int n = 0;  // one process owns the store: whatever runs at its start was left by a crash
  for (auto& [id, job] : t().jobs) {
    if (job.state != JobState::kRunning) continue;
    job.state = JobState::kQueued;
    job.message = "resumed after restart";
    job.lease_owner.reset();
    job.lease_expires_ms.reset();
    ++n;
  }
  return n;
}

std::set<std::string> MemoryJobStore::TilesDone(int64_t job_id) {
  auto lock = Lock();
  auto it = t().job_tiles.find(job_id);
  return it == t().job_tiles.end() ? std::set<std::string>() : it->second;
}

std::vector<std::pair<JobState, int64_t>> MemoryJobStore::CountByState() {
  auto lock = Lock();
  std::map<JobState, int64_t> counts;
  for (const auto& [id, job] : t().jobs) counts[job.state] += 1;
  return {counts.begin(), counts.end()};
}

}  // namespace mapdelta::server
