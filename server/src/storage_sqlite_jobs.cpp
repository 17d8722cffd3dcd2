// SQLite job store: the job queue and the tiles each job applied.
#include "storage_sqlite.hpp"

namespace mapdelta::server {

namespace {
constexpr const char* kJobColumns =
    "id, type, state, params_json, progress, message, result_json, cancel_requested, attempts, "
    "created_ms, started_ms, finished_ms, lease_owner, lease_expires_ms";

JobRecord ReadJob(sql::Stmt& s) {
  JobRecord j;
  j.id = s.Int(0);
  j.type = ParseEnumOrThrow<JobType>(s.Text(1), "jobs.type");
  j.state = ParseEnumOrThrow<JobState>(s.Text(2), "jobs.state");
  j.params_json = s.Text(3);
  j.progress = s.Real(4);
  j.message = s.Text(5);
  j.result_json = s.OptText(6);
  j.cancel_requested = s.Int(7) != 0;
  j.attempts = s.Int(8);
  j.created_ms = s.Int(9);
  if (!s.IsNull(10)) j.started_ms = s.Int(10);
  if (!s.IsNull(11)) j.finished_ms = s.Int(11);
  j.lease_owner = s.OptText(12);
  if (!s.IsNull(13)) j.lease_expires_ms = s.Int(13);
  return j;
}

}  // namespace

int64_t SqliteJobStore::Create(JobType type, const std::string& params_json, int64_t now_ms) {
  auto lock = Lock();
  sql::Stmt s(db(), "INSERT INTO jobs (type, state, params_json, created_ms) VALUES (?,?,?,?)");
  s.Bind(1, ToString(type))
      .Bind(2, ToString(JobState::kQueued))
      .Bind(3, params_json)
      .Bind(4, now_ms)
      .Run();
  return db().LastInsertId();
}

std::optional<JobRecord> SqliteJobStore::Get(int64_t id) {
  auto lock = Lock();
  sql::Stmt s(db(), std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?");
  s.Bind(1, id);
  if (!s.Step()) return std::nullopt;
  return ReadJob(s);
}

std::vector<JobRecord> SqliteJobStore::List(int64_t limit, int64_t offset) {
  auto lock = Lock();
  sql::Stmt s(
      db(), std::string("SELECT ") + kJobColumns + " FROM jobs ORDER BY id DESC LIMIT ? OFFSET ?");
  s.Bind(1, limit).Bind(2, offset);
  std::vector<JobRecord> out;
  while (s.Step()) out.push_back(ReadJob(s));
  return out;
}

std::optional<JobRecord> SqliteJobStore::ClaimNext(int64_t now_ms, int64_t lease_ms) {
  auto lock = Lock();
  sql::Transaction tx(db());
  int64_t id = 0;
  {
    // Queued, or running under a lease that ran out (its worker died).
    sql::Stmt s(db(),
                "SELECT id FROM jobs WHERE state = ? OR (state = ? AND "
                "COALESCE(lease_expires_ms, 0) < ?) ORDER BY id LIMIT 1");
    s.Bind(1, ToString(JobState::kQueued)).Bind(2, ToString(JobState::kRunning)).Bind(3, now_ms);
    if (!s.Step()) return std::nullopt;
    id = s.Int(0);
  }
  sql::Stmt u(db(),
              "UPDATE jobs SET state = ?, attempts = attempts + 1, "
              "started_ms = COALESCE(started_ms, ?), lease_owner = ?, lease_expires_ms = ? "
              "WHERE id = ?");
  u.Bind(1, ToString(JobState::kRunning))
      .Bind(2, now_ms)
      .Bind(3, worker_id_)
      .Bind(4, now_ms + lease_ms)
      .Bind(5, id)
      .Run();
  sql::Stmt s(db(), std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?");
  s.Bind(1, id);
  s.Step();
  JobRecord j = ReadJob(s);
  tx.Commit();
  return j;
}

bool SqliteJobStore::RenewLease(int64_t id, int64_t now_ms, int64_t lease_ms) {
  auto lock = Lock();
  sql::Stmt s(
      db(), "UPDATE jobs SET lease_expires_ms = ? WHERE id = ? AND lease_owner = ? AND state = ?");
  s.Bind(1, now_ms + lease_ms)
      .Bind(2, id)
      .Bind(3, worker_id_)
      .Bind(4, ToString(JobState::kRunning))
      .Run();
  return db().Changes() > 0;
}

void SqliteJobStore::Release(int64_t id) {
  auto lock = Lock();
  sql::Stmt s(db(),
              "UPDATE jobs SET state = ?, lease_owner = NULL, lease_expires_ms = NULL "
              "WHERE id = ? AND lease_owner = ? AND state = ?");
  s.Bind(1, ToString(JobState::kQueued))
      .Bind(2, id)
      .Bind(3, worker_id_)
      .Bind(4, ToString(JobState::kRunning))
      .Run();
}

std::optional<EarlierJob> SqliteJobStore::UnfinishedBefore(int64_t job_id, int64_t now_ms,
                                                           std::optional<JobType> type) {
  auto lock = Lock();
  sql::Stmt s(db(),
              "SELECT id, state = ? OR COALESCE(lease_expires_ms, 0) < ? FROM jobs "
              "WHERE id < ? AND state IN (?, ?) AND (? IS NULL OR type = ?) ORDER BY id LIMIT 1");
  const std::optional<std::string> type_name =
      type ? std::optional<std::string>(std::string(ToString(*type))) : std::nullopt;
  s.Bind(1, ToString(JobState::kQueued))
      .Bind(2, now_ms)
      .Bind(3, job_id)
      .Bind(4, ToString(JobState::kQueued))
      .Bind(5, ToString(JobState::kRunning))
      .Bind(6, type_name)
      .Bind(7, type_name);
  if (!s.Step()) return std::nullopt;
  return EarlierJob{s.Int(0), s.Int(1) != 0};
}

void SqliteJobStore::UpdateProgress(int64_t id, double progress, const std::string& message) {
  auto lock = Lock();
  sql::Stmt s(db(), "UPDATE jobs SET progress = ?, message = ? WHERE id = ?");
  s.Bind(1, progress).Bind(2, message).Bind(3, id).Run();
}

void SqliteJobStore::Finish(int64_t id, JobState state, const std::string& message,
                            const std::optional<std::string>& result_json, int64_t now_ms) {
  auto lock = Lock();
  sql::Stmt s(db(),
              "UPDATE jobs SET state = ?, message = ?, result_json = ?, finished_ms = ?, "
              "progress = CASE WHEN ? THEN 1.0 ELSE progress END, lease_owner = NULL, "
              "lease_expires_ms = NULL WHERE id = ?");
  s.Bind(1, ToString(state))
      .Bind(2, message)
      .Bind(3, result_json)
      .Bind(4, now_ms)
      .Bind(5, int64_t{state == JobState::kSucceeded})
      .Bind(6, id)
      .Run();
}

std::optional<JobState> SqliteJobStore::RequestCancel(int64_t id, int64_t now_ms) {
  auto lock = Lock();
  sql::Transaction tx(db());
  JobState state;
  {
    sql::Stmt s(db(), "SELECT state FROM jobs WHERE id = ?");
    s.Bind(1, id);
    if (!s.Step()) return std::nullopt;
    state = ParseEnumOrThrow<JobState>(s.Text(0), "jobs.state");
  }
  if (state == JobState::kQueued) {
    sql::Stmt u(db(),
                "UPDATE jobs SET state = ?, cancel_requested = 1, finished_ms = ?, "
                "message = 'cancelled before it started' WHERE id = ?");
    u.Bind(1, ToString(JobState::kCancelled)).Bind(2, now_ms).Bind(3, id).Run();
    // A cancelled commit leaves its session open so that the vehicle can commit again.
    sql::Stmt r(db(), "UPDATE sessions SET state = ?, job_id = NULL WHERE job_id = ?");
    r.Bind(1, ToString(SessionState::kOpen)).Bind(2, id).Run();
    state = JobState::kCancelled;
  } else if (state == JobState::kRunning) {
    sql::Stmt u(db(), "UPDATE jobs SET cancel_requested = 1 WHERE id = ?");
    u.Bind(1, id).Run();
  }
  tx.Commit();
  return state;
}

bool SqliteJobStore::IsCancelRequested(int64_t id) {
  auto lock = Lock();
  sql::Stmt s(db(), "SELECT cancel_requested FROM jobs WHERE id = ?");
  s.Bind(1, id);
  return s.Step() && s.Int(0) != 0;
}

int SqliteJobStore::RequeueInterrupted(int64_t /*now_ms*/) {
  auto lock = Lock();
  // One process per SQLite file: whatever is running at its start was left by a crash.
  sql::Stmt s(db(),
              "UPDATE jobs SET state = ?, message = 'resumed after restart', lease_owner = NULL, "
              "lease_expires_ms = NULL WHERE state = ?");
  s.Bind(1, ToString(JobState::kQueued)).Bind(2, ToString(JobState::kRunning)).Run();
  return db().Changes();
}

std::set<std::string> SqliteJobStore::TilesDone(int64_t job_id) {
  auto lock = Lock();
  sql::Stmt s(db(), "SELECT tile FROM job_tiles WHERE job_id = ?");
  s.Bind(1, job_id);
  std::set<std::string> out;
  while (s.Step()) out.insert(s.Text(0));
  return out;
}

std::vector<std::pair<JobState, int64_t>> SqliteJobStore::CountByState() {
  auto lock = Lock();
  sql::Stmt s(db(), "SELECT state, COUNT(*) FROM jobs GROUP BY state");
  std::vector<std::pair<JobState, int64_t>> out;
  while (s.Step()) out.emplace_back(ParseEnumOrThrow<JobState>(s.Text(0), "jobs.state"), s.Int(1));
  return out;
}

}  // namespace mapdelta::server
