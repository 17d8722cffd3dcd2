// Chooses the storage backend from the config (storage.backend).
#include "mapdelta/common/error.hpp"
#include "mapdelta/server/storage.hpp"
#include "pg_db.hpp"

namespace mapdelta::server {

std::unique_ptr<Storage> OpenConfiguredStorage(const ServerConfig& config) {
  const StorageConfig& storage = config.storage;
  if (storage.backend == "postgres") {
    // Every thread that may call storage at once gets a connection: none waits for one.
    const int connections = config.http.threads + config.pipeline.threads + 2;
    return OpenPostgresStorage(storage.postgres_url, connections);
  }
  if (storage.backend == "sqlite") return OpenSqliteStorage(storage.database);
  throw Error(ErrorCode::kInvalidArgument,
              "storage.backend: must be sqlite or postgres (got '" + storage.backend + "')");
}

std::string RedactPostgresUrl(const std::string& conninfo) {
  return conninfo.empty() ? std::string() : pg::RedactConninfo(conninfo);
}

}  // namespace mapdelta::server
