// SQLite per-tile work of commit jobs (JobStore::AddTileWork .. ListTileWork) and its
// publication (TileStore::PublishTileWork). One process owns a SQLite database, so a claim is
// a read and an update in one transaction under the connection's mutex; the contract (one
// claim per item, leases, the fencing token) is the PostgreSQL backend's.
#include "storage_sqlite.hpp"

namespace mapdelta::server {
namespace {

constexpr const char* kItemColumns =
    "job_id, ix, iy, prior_version, claims, lease_owner, lease_expires_ms, done_by, new_count, "
    "removed_count, published";

TileWorkItem ReadItem(sql::Stmt& s) {
  TileWorkItem w;
  w.job_id = s.Int(0);
  w.tile = TileId(static_cast<int32_t>(s.Int(1)), static_cast<int32_t>(s.Int(2)));
  w.prior_version = s.Int(3);
  w.claims = s.Int(4);
  w.lease_owner = s.OptText(5);
  if (!s.IsNull(6)) w.lease_expires_ms = s.Int(6);
  w.done_by = s.OptText(7);
  w.new_count = s.Int(8);
  w.removed_count = s.Int(9);
  w.published = s.Int(10) != 0;
  return w;
}

}  // namespace

void SqliteJobStore::AddTileWork(int64_t job_id, int64_t prior_version,
                                 const std::vector<TileId>& tiles) {
  auto lock = Lock();
  sql::Transaction tx(db());
  for (const TileId& tile : tiles) {
    sql::Stmt s(db(),
                "INSERT OR IGNORE INTO tile_work (job_id, tile, ix, iy, prior_version) "
                "VALUES (?,?,?,?,?)");
    s.Bind(1, job_id)
        .Bind(2, tile.ToString())
        .Bind(3, int64_t{tile.ix()})
        .Bind(4, int64_t{tile.iy()})
        .Bind(5, prior_version)
        .Run();
  }
  tx.Commit();
}

std::optional<TileWorkItem> SqliteJobStore::ClaimTileWork(std::optional<int64_t> job_id,
                                                          int64_t now_ms, int64_t lease_ms) {
  auto lock = Lock();
  sql::Transaction tx(db());
  int64_t claimed_job = 0;
  std::string tile;
  {
    sql::Stmt s(db(),
                "SELECT w.job_id, w.tile FROM tile_work w JOIN jobs j ON j.id = w.job_id "
                "WHERE j.state = ? AND w.done_by IS NULL AND (w.lease_owner IS NULL OR "
                "COALESCE(w.lease_expires_ms, 0) < ?) AND (? IS NULL OR w.job_id = ?) "
                "ORDER BY w.job_id, w.ix, w.iy LIMIT 1");
    s.Bind(1, ToString(JobState::kRunning)).Bind(2, now_ms);
    if (job_id) {
      s.Bind(3, *job_id).Bind(4, *job_id);
    } else {
      s.BindNull(3).BindNull(4);
    }
    if (!s.Step()) return std::nullopt;
    claimed_job = s.Int(0);
    tile = s.Text(1);
  }
  sql::Stmt u(db(), std::string("UPDATE tile_work SET claims = claims + 1, lease_owner = ?, "
                                "lease_expires_ms = ? WHERE job_id = ? AND tile = ? RETURNING ") +
                        kItemColumns);
  u.Bind(1, worker_id_).Bind(2, now_ms + lease_ms).Bind(3, claimed_job).Bind(4, tile);
  if (!u.Step()) return std::nullopt;
  TileWorkItem item = ReadItem(u);
  u.Reset();
  tx.Commit();
  return item;
}

bool SqliteJobStore::CompleteTileWork(const TileWorkItem& claimed,
                                      const TileChangesRecord& result) {
  auto lock = Lock();
  sql::Stmt s(db(),
              "UPDATE tile_work SET done_by = lease_owner, lease_owner = NULL, "
              "lease_expires_ms = NULL, new_count = ?, removed_count = ?, max_confidence = ?, "
              "changes = ?, params_json = ?, updated_ms = ? WHERE job_id = ? AND tile = ? AND "
              "claims = ? AND lease_owner = ? AND done_by IS NULL");
  s.Bind(1, result.new_count)
      .Bind(2, result.removed_count)
      .Bind(3, result.max_confidence)
      .Bind(4, result.changes)
      .Bind(5, result.params_json)
      .Bind(6, result.updated_ms)
      .Bind(7, claimed.job_id)
      .Bind(8, claimed.tile.ToString())
      .Bind(9, claimed.claims)
      .Bind(10, worker_id_)
      .Run();
  return db().Changes() > 0;
}

std::vector<TileWorkItem> SqliteJobStore::ListTileWork(int64_t job_id) {
  auto lock = Lock();
  sql::Stmt s(db(), std::string("SELECT ") + kItemColumns +
                        " FROM tile_work WHERE job_id = ? ORDER BY ix, iy");
  s.Bind(1, job_id);
  std::vector<TileWorkItem> out;
  while (s.Step()) out.push_back(ReadItem(s));
  return out;
}

PublishOutcome SqliteTileStore::PublishTileWork(int64_t job_id) {
  auto lock = Lock();
  sql::Transaction tx(db());
  {
    sql::Stmt s(db(),
                "SELECT COUNT(*), COALESCE(SUM(done_by IS NULL), 0), COALESCE(SUM(published), 0) "
                "FROM tile_work WHERE job_id = ?");
    s.Bind(1, job_id);
    s.Step();
    if (s.Int(2) > 0) return PublishOutcome::kAlreadyPublished;
    if (s.Int(0) == 0 || s.Int(1) > 0) return PublishOutcome::kNotReady;
  }
  sql::Stmt copy(
      db(),
      "INSERT OR REPLACE INTO tile_changes (tile, ix, iy, prior_version, new_count, "
      "removed_count, max_confidence, changes, params_json, updated_ms) "
      "SELECT tile, ix, iy, prior_version, new_count, removed_count, max_confidence, "
      "changes, params_json, updated_ms FROM tile_work WHERE job_id = ? ORDER BY ix, iy");
  copy.Bind(1, job_id).Run();
  if (lifecycle_) {
    sql::Stmt staged(
        db(),
        "SELECT ix, iy, prior_version, new_count, removed_count, max_confidence, "
        "changes, params_json, updated_ms FROM tile_work WHERE job_id = ? ORDER BY ix, iy");
    staged.Bind(1, job_id);
    while (staged.Step()) {
      TileChangesRecord c;
      c.tile = TileId(static_cast<int32_t>(staged.Int(0)), static_cast<int32_t>(staged.Int(1)));
      c.prior_version = staged.Int(2);
      c.new_count = staged.Int(3);
      c.removed_count = staged.Int(4);
      c.max_confidence = staged.Real(5);
      c.changes = staged.Blob(6);
      c.params_json = staged.Text(7);
      c.updated_ms = staged.Int(8);
      ReconcileTileClustersSqlite(db(), lifecycle_.get(),
                                  {c.tile, job_id, c.updated_ms, &c, nullptr, 0, {}});
    }
  }
  sql::Stmt mark(db(), "UPDATE tile_work SET published = 1, changes = NULL WHERE job_id = ?");
  mark.Bind(1, job_id).Run();
  tx.Commit();
  return PublishOutcome::kPublished;
}

}  // namespace mapdelta::server
