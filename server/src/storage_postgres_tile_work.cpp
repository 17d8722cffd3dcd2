// PostgreSQL per-tile work of commit jobs (JobStore::AddTileWork .. ListTileWork) and its
// publication (TileStore::PublishTileWork), for several worker processes on one database:
// items are claimed with FOR UPDATE SKIP LOCKED (two workers never get the same item and never
// wait for each other), completions are fenced by the claim count, and publication locks the
// job's items so that two workers finishing at once publish once.
#include "storage_postgres.hpp"

namespace mapdelta::server {
namespace {

constexpr const char* kItemColumns =
    "job_id, ix, iy, prior_version, claims, lease_owner, lease_expires_ms, done_by, new_count, "
    "removed_count, published";

TileWorkItem ReadItem(const pg::Result& r, int row) {
  TileWorkItem w;
  w.job_id = r.Int(row, 0);
  w.tile = TileId(static_cast<int32_t>(r.Int(row, 1)), static_cast<int32_t>(r.Int(row, 2)));
  w.prior_version = r.Int(row, 3);
  w.claims = r.Int(row, 4);
  w.lease_owner = r.OptText(row, 5);
  w.lease_expires_ms = r.OptInt(row, 6);
  w.done_by = r.OptText(row, 7);
  w.new_count = r.Int(row, 8);
  w.removed_count = r.Int(row, 9);
  w.published = r.Int(row, 10) != 0;
  return w;
}

}  // namespace

void PostgresJobStore::AddTileWork(int64_t job_id, int64_t prior_version,
                                   const std::vector<TileId>& tiles) {
  auto c = Connect();
  pg::Transaction tx(*c);
  for (const TileId& tile : tiles) {
    c->Query(
        "INSERT INTO tile_work (job_id, tile, ix, iy, prior_version) VALUES ($1,$2,$3,$4,$5) "
        "ON CONFLICT DO NOTHING",
        pg::Params()
            .Add(job_id)
            .Add(tile.ToString())
            .Add(int64_t{tile.ix()})
            .Add(int64_t{tile.iy()})
            .Add(prior_version));
  }
  tx.Commit();
}

std::optional<TileWorkItem> PostgresJobStore::ClaimTileWork(std::optional<int64_t> job_id,
                                                            int64_t now_ms, int64_t lease_ms) {
  auto c = Connect();
  const pg::Result r = c->Query(
      std::string(
          "UPDATE tile_work SET claims = claims + 1, lease_owner = $1, lease_expires_ms = "
          "$2::bigint + $3::bigint WHERE (job_id, tile) = (SELECT job_id, tile FROM tile_work "
          "WHERE done_by IS NULL AND (lease_owner IS NULL OR COALESCE(lease_expires_ms, 0) < "
          "$2::bigint) AND ($4::bigint IS NULL OR job_id = $4::bigint) AND job_id IN (SELECT "
          "id FROM jobs WHERE state = $5) ORDER BY job_id, ix, iy LIMIT 1 FOR UPDATE SKIP "
          "LOCKED) RETURNING ") +
          kItemColumns,
      pg::Params().Add(worker()).Add(now_ms).Add(lease_ms).Add(job_id).Add(
          ToString(JobState::kRunning)));
  if (r.rows() == 0) return std::nullopt;
  return ReadItem(r, 0);
}

bool PostgresJobStore::CompleteTileWork(const TileWorkItem& claimed,
                                        const TileChangesRecord& result) {
  auto c = Connect();
  // Fenced in the row update itself: a worker whose claim was taken over (claims moved on)
  // changes nothing.
  return c->Query(
              "UPDATE tile_work SET done_by = lease_owner, lease_owner = NULL, "
              "lease_expires_ms = NULL, new_count = $1, removed_count = $2, max_confidence = $3, "
              "changes = $4, params_json = $5, updated_ms = $6 WHERE job_id = $7 AND tile = $8 "
              "AND claims = $9 AND lease_owner = $10 AND done_by IS NULL",
              pg::Params()
                  .Add(result.new_count)
                  .Add(result.removed_count)
                  .Add(result.max_confidence)
                  .Add(result.changes)
                  .Add(result.params_json)
                  .Add(result.updated_ms)
                  .Add(claimed.job_id)
                  .Add(claimed.tile.ToString())
                  .Add(claimed.claims)
                  .Add(worker()))
             .affected() > 0;
}

std::vector<TileWorkItem> PostgresJobStore::ListTileWork(int64_t job_id) {
  auto c = Connect();
  const pg::Result r = c->Query(
      std::string("SELECT ") + kItemColumns + " FROM tile_work WHERE job_id = $1 ORDER BY ix, iy",
      pg::Params().Add(job_id));
  std::vector<TileWorkItem> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(ReadItem(r, i));
  return out;
}

PublishOutcome PostgresTileStore::PublishTileWork(int64_t job_id) {
  auto c = Connect();
  pg::Transaction tx(*c);
  pg_rows::LockClusterFeed(*c, lifecycle_.get());
  // Locks the job's items: a completion or a second publisher waits for this transaction.
  const pg::Result r =
      c->Query("SELECT done_by IS NULL, published FROM tile_work WHERE job_id = $1 FOR UPDATE",
               pg::Params().Add(job_id));
  bool pending = r.rows() == 0;
  for (int i = 0; i < r.rows(); ++i) {
    if (r.Int(i, 1) != 0) return PublishOutcome::kAlreadyPublished;
    pending = pending || r.Bool(i, 0);
  }
  if (pending) return PublishOutcome::kNotReady;
  c->Query(std::string("INSERT INTO tile_changes (tile, ix, iy, prior_version, new_count, "
                       "removed_count, max_confidence, changes, params_json, updated_ms) "
                       "SELECT tile, ix, iy, prior_version, new_count, removed_count, "
                       "max_confidence, changes, params_json, updated_ms FROM tile_work "
                       "WHERE job_id = $1 ") +
               pg_rows::kUpsertTileChanges,
           pg::Params().Add(job_id));
  if (lifecycle_) {
    const pg::Result staged = c->Query(
        "SELECT ix, iy, prior_version, new_count, removed_count, max_confidence, changes, "
        "params_json, updated_ms FROM tile_work WHERE job_id = $1 ORDER BY ix, iy",
        pg::Params().Add(job_id));
    for (int i = 0; i < staged.rows(); ++i) {
      TileChangesRecord t;
      t.tile =
          TileId(static_cast<int32_t>(staged.Int(i, 0)), static_cast<int32_t>(staged.Int(i, 1)));
      t.prior_version = staged.Int(i, 2);
      t.new_count = staged.Int(i, 3);
      t.removed_count = staged.Int(i, 4);
      t.max_confidence = staged.Real(i, 5);
      t.changes = staged.Bytes(i, 6);
      t.params_json = staged.Text(i, 7);
      t.updated_ms = staged.Int(i, 8);
      pg_rows::ReconcileTileClusters(*c, lifecycle_.get(),
                                     {t.tile, job_id, t.updated_ms, &t, nullptr, 0, {}});
    }
  }
  c->Query("UPDATE tile_work SET published = 1, changes = NULL WHERE job_id = $1",
           pg::Params().Add(job_id));
  tx.Commit();
  return PublishOutcome::kPublished;
}

}  // namespace mapdelta::server
