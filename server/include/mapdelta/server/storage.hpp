#pragma once
// The server's storage: one database seen through five per-area stores. Blobs are opaque here
// (the service layer encodes them), so a backend needs only the store headers' contract, which
// tests/server/test_storage_contract.cpp checks for every backend. Every store method is
// atomic: it applies fully or throws. The few writes that span areas (a commit queues its job,
// a cancel reopens its session, a refresh writes a prior version) belong to the store that
// starts them and take the other areas' rows in the same transaction, so a backend's stores
// share one connection (or pool) and one transaction scope.
#include <memory>
#include <string>

#include "mapdelta/server/job_store.hpp"
#include "mapdelta/server/prior_store.hpp"
#include "mapdelta/server/session_store.hpp"
#include "mapdelta/server/tile_store.hpp"
#include "mapdelta/server/token_store.hpp"

namespace mapdelta::server {

class Storage {
 public:
  // One backend's stores; all five are required.
  struct Stores {
    std::unique_ptr<TokenStore> tokens;
    std::unique_ptr<PriorStore> priors;
    std::unique_ptr<SessionStore> sessions;
    std::unique_ptr<JobStore> jobs;
    std::unique_ptr<TileStore> tiles;
  };
  explicit Storage(Stores stores);  // throws Error(kInternal) if a store is missing

  TokenStore& tokens() { return *stores_.tokens; }
  PriorStore& priors() { return *stores_.priors; }
  SessionStore& sessions() { return *stores_.sessions; }
  JobStore& jobs() { return *stores_.jobs; }
  TileStore& tiles() { return *stores_.tiles; }

 private:
  Stores stores_;
};

// Opens (creating) the SQLite database and applies pending migrations in one transaction.
// Throws Error(kUnsupported) if the database's schema is newer than this build knows.
std::unique_ptr<Storage> OpenSqliteStorage(const std::string& path);
// Highest migration this build knows.
int KnownSchemaVersion();

}  // namespace mapdelta::server
