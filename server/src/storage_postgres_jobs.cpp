// PostgreSQL job store: the job queue and the tiles each job applied.
#include "storage_postgres.hpp"

namespace mapdelta::server {
namespace {

constexpr const char* kJobColumns =
    "id, type, state, params_json, progress, message, result_json, "
    "cancel_requested, attempts, "
    "created_ms, started_ms, finished_ms, lease_owner, lease_expires_ms";

JobRecord ReadJob(const pg::Result& r, int row) {
  JobRecord j;
  j.id = r.Int(row, 0);
  j.type = ParseEnumOrThrow<JobType>(r.Text(row, 1), "jobs.type");
  j.state = ParseEnumOrThrow<JobState>(r.Text(row, 2), "jobs.state");
  j.params_json = r.Text(row, 3);
  j.progress = r.Real(row, 4);
  j.message = r.Text(row, 5);
  j.result_json = r.OptText(row, 6);
  j.cancel_requested = r.Int(row, 7) != 0;
  j.attempts = r.Int(row, 8);
  j.created_ms = r.Int(row, 9);
  j.started_ms = r.OptInt(row, 10);
  j.finished_ms = r.OptInt(row, 11);
  j.lease_owner = r.OptText(row, 12);
  j.lease_expires_ms = r.OptInt(row, 13);
  return j;
}

}  // namespace

int64_t PostgresJobStore::Create(JobType type, const std::string& params_json, int64_t now_ms) {
  auto c = Connect();
  return c
      ->Query(
          "INSERT INTO jobs (type, state, params_json, created_ms) VALUES "
          "($1,$2,$3,$4) "
          "RETURNING id",
          pg::Params()
              .Add(ToString(type))
              .Add(ToString(JobState::kQueued))
              .Add(params_json)
              .Add(now_ms))
      .Int(0, 0);
}

std::optional<JobRecord> PostgresJobStore::Get(int64_t id) {
  auto c = Connect();
  const pg::Result r = c->Query(std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = $1",
                                pg::Params().Add(id));
  if (r.rows() == 0) return std::nullopt;
  return ReadJob(r, 0);
}

std::vector<JobRecord> PostgresJobStore::List(int64_t limit, int64_t offset) {
  auto c = Connect();
  const pg::Result r = c->Query(
      std::string("SELECT ") + kJobColumns + " FROM jobs ORDER BY id DESC LIMIT $1 OFFSET $2",
      pg::Params().Add(limit).Add(offset));
  std::vector<JobRecord> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(ReadJob(r, i));
  return out;
}

std::optional<JobRecord> PostgresJobStore::ClaimNext(int64_t now_ms, int64_t lease_ms) {
  auto c = Connect();
  // SKIP LOCKED: a job another process is claiming at this moment is passed over, not waited for,
  // so two workers never claim the same job and never queue behind each other. A running job whose
  // lease ran out belongs to a worker that died: it is claimed again.
  const pg::Result r = c->Query(
      std::string("UPDATE jobs SET state = $1, attempts = attempts + 1, "
                  "started_ms = COALESCE(started_ms, $2::bigint), lease_owner = $3, "
                  "lease_expires_ms = $2::bigint + $4::bigint WHERE id = (SELECT id FROM jobs "
                  "WHERE state = $5 OR (state = $1 AND COALESCE(lease_expires_ms, 0) < $2) "
                  "ORDER BY id LIMIT 1 FOR UPDATE SKIP LOCKED) RETURNING ") +
          kJobColumns,
      pg::Params()
          .Add(ToString(JobState::kRunning))
          .Add(now_ms)
          .Add(worker())
          .Add(lease_ms)
          .Add(ToString(JobState::kQueued)));
  if (r.rows() == 0) return std::nullopt;
  return ReadJob(r, 0);
}

bool PostgresJobStore::RenewLease(int64_t id, int64_t now_ms, int64_t lease_ms) {
  auto c = Connect();
  return c->Query(
              "UPDATE jobs SET lease_expires_ms = $1::bigint + $2::bigint WHERE id = $3 AND "
              "lease_owner = $4 AND state = $5",
              pg::Params().Add(now_ms).Add(lease_ms).Add(id).Add(worker()).Add(
                  ToString(JobState::kRunning)))
             .affected() > 0;
}

void PostgresJobStore::Release(int64_t id) {
  auto c = Connect();
  c->Query(
      "UPDATE jobs SET state = $1, lease_owner = NULL, lease_expires_ms = NULL "
      "WHERE id = $2 AND lease_owner = $3 AND state = $4",
      pg::Params()
          .Add(ToString(JobState::kQueued))
          .Add(id)
          .Add(worker())
          .Add(ToString(JobState::kRunning)));
}

std::optional<EarlierJob> PostgresJobStore::UnfinishedBefore(int64_t job_id, int64_t now_ms,
                                                             std::optional<JobType> type) {
  auto c = Connect();
  const std::optional<std::string> type_name =
      type ? std::optional<std::string>(std::string(ToString(*type))) : std::nullopt;
  const pg::Result r = c->Query(
      "SELECT id, state = $1 OR COALESCE(lease_expires_ms, 0) < $2::bigint FROM jobs "
      "WHERE id < $3 AND state IN ($1, $4) AND ($5::text IS NULL OR type = $5) "
      "ORDER BY id LIMIT 1",
      pg::Params()
          .Add(ToString(JobState::kQueued))
          .Add(now_ms)
          .Add(job_id)
          .Add(ToString(JobState::kRunning))
          .Add(type_name));
  if (r.rows() == 0) return std::nullopt;
  return EarlierJob{r.Int(0, 0), r.Bool(0, 1)};
}

void PostgresJobStore::UpdateProgress(int64_t id, double progress, const std::string& message) {
  auto c = Connect();
  c->Query("UPDATE jobs SET progress = $1, message = $2 WHERE id = $3",
           pg::Params().Add(progress).Add(message).Add(id));
}

void PostgresJobStore::Finish(int64_t id, JobState state, const std::string& message,
                              const std::optional<std::string>& result_json, int64_t now_ms) {
  auto c = Connect();
  // Fenced: a worker whose job was taken over (another holds the lease) finishes nothing.
  c->Query(
      "UPDATE jobs SET state = $1, message = $2, result_json = $3, finished_ms = $4, "
      "progress = CASE WHEN $5 THEN 1.0 ELSE progress END, lease_owner = NULL, "
      "lease_expires_ms = NULL WHERE id = $6 AND (lease_owner IS NULL OR lease_owner = $7)",
      pg::Params()
          .Add(ToString(state))
          .Add(message)
          .Add(result_json)
          .Add(now_ms)
          .Add(state == JobState::kSucceeded ? "true" : "false")
          .Add(id)
          .Add(worker()));
}

std::optional<JobState> PostgresJobStore::RequestCancel(int64_t id, int64_t now_ms) {
  auto c = Connect();
  pg::Transaction tx(*c);
  const pg::Result r =
      c->Query("SELECT state FROM jobs WHERE id = $1 FOR UPDATE", pg::Params().Add(id));
  if (r.rows() == 0) return std::nullopt;
  JobState state = ParseEnumOrThrow<JobState>(r.Text(0, 0), "jobs.state");
  if (state == JobState::kQueued) {
    c->Query(
        "UPDATE jobs SET state = $1, cancel_requested = 1, finished_ms = $2, "
        "message = 'cancelled before it started' WHERE id = $3",
        pg::Params().Add(ToString(JobState::kCancelled)).Add(now_ms).Add(id));
    // A cancelled commit leaves its session open so that the vehicle can commit again.
    c->Query("UPDATE sessions SET state = $1, job_id = NULL WHERE job_id = $2",
             pg::Params().Add(ToString(SessionState::kOpen)).Add(id));
    state = JobState::kCancelled;
  } else if (state == JobState::kRunning) {
    c->Query("UPDATE jobs SET cancel_requested = 1 WHERE id = $1", pg::Params().Add(id));
  }
  tx.Commit();
  return state;
}

bool PostgresJobStore::IsCancelRequested(int64_t id) {
  auto c = Connect();
  const pg::Result r =
      c->Query("SELECT cancel_requested FROM jobs WHERE id = $1", pg::Params().Add(id));
  return r.rows() > 0 && r.Int(0, 0) != 0;
}

int PostgresJobStore::RequeueInterrupted(int64_t now_ms) {
  auto c = Connect();
  // Other workers may be alive and renewing their leases: only lapsed ones are requeued.
  return static_cast<int>(
      c->Query("UPDATE jobs SET state = $1, message = 'resumed after restart', lease_owner = NULL, "
               "lease_expires_ms = NULL WHERE state = $2 AND COALESCE(lease_expires_ms, 0) < $3",
               pg::Params()
                   .Add(ToString(JobState::kQueued))
                   .Add(ToString(JobState::kRunning))
                   .Add(now_ms))
          .affected());
}

std::set<std::string> PostgresJobStore::TilesDone(int64_t job_id) {
  auto c = Connect();
  const pg::Result r =
      c->Query("SELECT tile FROM job_tiles WHERE job_id = $1", pg::Params().Add(job_id));
  std::set<std::string> out;
  for (int i = 0; i < r.rows(); ++i) out.insert(r.Text(i, 0));
  return out;
}

std::vector<std::pair<JobState, int64_t>> PostgresJobStore::CountByState() {
  auto c = Connect();
  const pg::Result r = c->Query("SELECT state, COUNT(*) FROM jobs GROUP BY state");
  std::vector<std::pair<JobState, int64_t>> out;
  for (int i = 0; i < r.rows(); ++i) {
    out.emplace_back(ParseEnumOrThrow<JobState>(r.Text(i, 0), "jobs.state"), r.Int(i, 1));
  }
  return out;
}

}  // namespace mapdelta::server
