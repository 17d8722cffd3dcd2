#pragma once
// The server's storage: one database seen through seven per-area stores. Blobs are opaque here
// (the service layer encodes them), so a backend needs only the store headers' contract, which
// tests/server/test_storage_contract.cpp checks for every backend. Every store method is
// atomic: it applies fully or throws. The few writes that span areas (a commit queues its job,
// a cancel reopens its session, a refresh writes a prior version) belong to the store that
// starts them and take the other areas' rows in the same transaction, so a backend's stores
// share one connection (or pool) and one transaction scope.
#include <memory>
#include <string>

#include "mapdelta/server/change_cluster_store.hpp"
#include "mapdelta/server/config.hpp"
#include "mapdelta/server/coverage_store.hpp"
#include "mapdelta/server/job_store.hpp"
#include "mapdelta/server/prior_store.hpp"
#include "mapdelta/server/session_store.hpp"
#include "mapdelta/server/tile_store.hpp"
#include "mapdelta/server/token_store.hpp"

namespace mapdelta::server {

class Storage {
 public:
  // One backend's stores; all seven are required.
  struct Stores {
    std::unique_ptr<TokenStore> tokens;
    std::unique_ptr<PriorStore> priors;
    std::unique_ptr<SessionStore> sessions;
    std::unique_ptr<JobStore> jobs;
    std::unique_ptr<TileStore> tiles;
    std::unique_ptr<ChangeClusterStore> clusters;
    std::unique_ptr<CoverageStore> coverage;
  };
  explicit Storage(Stores stores);  // throws Error(kInternal) if a store is missing

  TokenStore& tokens() { return *stores_.tokens; }
  PriorStore& priors() { return *stores_.priors; }
  SessionStore& sessions() { return *stores_.sessions; }
  JobStore& jobs() { return *stores_.jobs; }
  TileStore& tiles() { return *stores_.tiles; }
  ChangeClusterStore& clusters() { return *stores_.clusters; }
  CoverageStore& coverage() { return *stores_.coverage; }

 private:
  Stores stores_;
};

// Opens (creating) the SQLite database and applies pending migrations in one transaction.
// Throws Error(kUnsupported) if the database's schema is newer than this build knows.
std::unique_ptr<Storage> OpenSqliteStorage(const std::string& path);
// Connects to PostgreSQL (a libpq URL or key=value string) with a pool of up to
// max_connections and applies pending migrations/postgres/*.sql in one transaction (one
// process at a time). Throws Error(kIo) if the server cannot be reached or refuses the login
// (one line: the target without its password, and libpq's reason), Error(kUnsupported) if the
// schema is newer than this build knows.
std::unique_ptr<Storage> OpenPostgresStorage(const std::string& conninfo, int max_connections);
// The backend config.storage.backend names; a PostgreSQL pool gets a connection for each
// thread that may call storage at once (HTTP workers, job threads, the job worker).
std::unique_ptr<Storage> OpenConfiguredStorage(const ServerConfig& config);
// A libpq connection string without its password (for logs and the effective config).
std::string RedactPostgresUrl(const std::string& conninfo);
// Highest migration this build knows (both backends are at the same version).
int KnownSchemaVersion();

}  // namespace mapdelta::server
