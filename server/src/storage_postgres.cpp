// PostgreSQL storage: connecting, migrating the schema, and the token store. The other stores are
// in storage_postgres_{priors,sessions,jobs,tiles}.cpp.
#include "storage_postgres.hpp"

#include "mapdelta/common/error.hpp"
#include "schema_migrator.hpp"

namespace mapdelta::server {
namespace {

// Runs inside the transaction OpenPostgresStorage opened, after its advisory lock: several
// processes starting at once on an empty database migrate once, the others wait and then find
// nothing left to do.
class PostgresSchemaTarget final : public SchemaTarget {
 public:
  explicit PostgresSchemaTarget(pg::Connection& c) : c_(c) {}
  int64_t AppliedVersion() override {
    c_.Exec(
        "CREATE TABLE IF NOT EXISTS schema_migrations (version BIGINT "
        "PRIMARY KEY, "
        "name TEXT NOT NULL, applied_ms BIGINT NOT NULL)");
    return c_.Query("SELECT COALESCE(MAX(version), 0)::bigint FROM schema_migrations").Int(0, 0);
  }
  void Apply(const Migration& m) override {
    c_.Exec(m.sql);
    c_.Query(
        "INSERT INTO schema_migrations VALUES ($1, $2, "
        "(EXTRACT(EPOCH FROM clock_timestamp()) * 1000)::bigint)",
        pg::Params().Add(int64_t{m.version}).Add(m.name));
  }

 private:
  pg::Connection& c_;
};

// Keys of transaction-scoped advisory locks (pg_advisory_xact_lock): any numbers, fixed here.
constexpr int64_t kMigrationLock = 0x6d64'0001;
constexpr int64_t kPriorVersionLock = 0x6d64'0002;

TokenRecord ReadToken(const pg::Result& r, int row) {
  TokenRecord t;
  t.id = r.Text(row, 0);
  t.name = r.Text(row, 1);
  t.role = ParseEnumOrThrow<Role>(r.Text(row, 2), "tokens.role");
  t.created_ms = r.Int(row, 3);
  t.revoked_ms = r.OptInt(row, 4);
  return t;
}

}  // namespace

std::unique_ptr<Storage> OpenPostgresStorage(const std::string& conninfo, int max_connections) {
  if (NewestVersion(EmbeddedPostgresMigrations()) != KnownSchemaVersion()) {
    throw Error(ErrorCode::kInternal,
                "migrations/postgres is at version " +
                    std::to_string(NewestVersion(EmbeddedPostgresMigrations())) +
                    " but migrations/ at " + std::to_string(KnownSchemaVersion()));
  }
  auto shared = std::make_shared<PostgresShared>(conninfo, max_connections);
  {
    auto c = shared->pool.Acquire();
    pg::Transaction tx(*c);
    c->Query("SELECT pg_advisory_xact_lock($1)", pg::Params().Add(kMigrationLock));
    PostgresSchemaTarget target(*c);
    MigrateSchema(target, EmbeddedPostgresMigrations());
    tx.Commit();
  }
  Storage::Stores stores;
  stores.tokens = std::make_unique<PostgresTokenStore>(shared);
  stores.priors = std::make_unique<PostgresPriorStore>(shared);
  stores.sessions = std::make_unique<PostgresSessionStore>(shared);
  stores.jobs = std::make_unique<PostgresJobStore>(shared);
  stores.tiles = std::make_unique<PostgresTileStore>(shared);
  stores.clusters = std::make_unique<PostgresClusterStore>(shared);
  stores.coverage = std::make_unique<PostgresCoverageStore>(shared);
  return std::make_unique<Storage>(std::move(stores));
}

namespace pg_rows {

int64_t LockPriorVersions(pg::Connection& c) {
  c.Query("SELECT pg_advisory_xact_lock($1)", pg::Params().Add(kPriorVersionLock));
  return c.Query("SELECT COALESCE(MAX(version), 0)::bigint FROM prior_versions").Int(0, 0);
}

void InsertPriorTile(pg::Connection& c, int64_t version, const std::string& tile, int64_t ix,
                     int64_t iy, int64_t point_count, const Bytes& points) {
  c.Query(
      "INSERT INTO prior_tiles (version, tile, ix, iy, point_count, points) "
      "VALUES ($1,$2,$3,$4,$5,$6)",
      pg::Params().Add(version).Add(tile).Add(ix).Add(iy).Add(point_count).Add(points));
}

void FenceJob(pg::Connection& c, int64_t job_id, const std::string& worker_id) {
  const pg::Result r =
      c.Query("SELECT lease_owner FROM jobs WHERE id = $1 FOR SHARE", pg::Params().Add(job_id));
  if (r.rows() == 0 || r.IsNull(0, 0) || r.Text(0, 0) == worker_id) return;
  throw Error(ErrorCode::kConflict, "job " + std::to_string(job_id) + " is leased to " +
                                        r.Text(0, 0) + ", not to this worker (" + worker_id +
                                        "): it was taken over");
}

pg::Params& AddTileRange(pg::Params& p, const Rect& r) {
  return p.Add(static_cast<int64_t>(r.min_x))
      .Add(static_cast<int64_t>(r.max_x))
      .Add(static_cast<int64_t>(r.min_y))
      .Add(static_cast<int64_t>(r.max_y));
}

}  // namespace pg_rows

// ---------------------------------------------------------------- tokens

void PostgresTokenStore::Insert(const TokenRecord& t, const std::string& hash) {
  auto c = Connect();
  c->Query(
      "INSERT INTO tokens (id, name, role, hash, created_ms) VALUES "
      "($1,$2,$3,$4,$5)",
      pg::Params().Add(t.id).Add(t.name).Add(ToString(t.role)).Add(hash).Add(t.created_ms));
}

std::optional<TokenRecord> PostgresTokenStore::FindActiveByHash(const std::string& hash) {
  auto c = Connect();
  const pg::Result r = c->Query(
      "SELECT id, name, role, created_ms, revoked_ms FROM tokens "
      "WHERE hash = $1 AND revoked_ms IS NULL",
      pg::Params().Add(hash));
  if (r.rows() == 0) return std::nullopt;
  return ReadToken(r, 0);
}

bool PostgresTokenStore::Revoke(const std::string& id, int64_t now_ms) {
  auto c = Connect();
  return c->Query(
              "UPDATE tokens SET revoked_ms = $1 WHERE id = $2 AND "
              "revoked_ms IS NULL",
              pg::Params().Add(now_ms).Add(id))
             .affected() > 0;
}

std::vector<TokenRecord> PostgresTokenStore::List() {
  auto c = Connect();
  const pg::Result r = c->Query(
      "SELECT id, name, role, created_ms, revoked_ms "
      "FROM tokens ORDER BY created_ms, id");
  std::vector<TokenRecord> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(ReadToken(r, i));
  return out;
}

}  // namespace mapdelta::server
