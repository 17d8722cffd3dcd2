#include "server_backends.hpp"

#include <stdexcept>

namespace mapdelta::testing {

TempPostgres& SharedPostgres() {
  static TempPostgres server;
  return server;
}

void UseFreshDatabase(const std::string& backend, const std::filesystem::path& dir,
                      server::ServerConfig* config) {
  config->storage.backend = backend;
  if (backend == "sqlite") {
    const std::filesystem::path db = dir / "db.sqlite";
    for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(db.string() + suffix);
    config->storage.database = db.string();
    return;
  }
  if (backend == "postgres") {
    static int databases = 0;  // unique within the process (one server per process)
    config->storage.postgres_url =
        SharedPostgres().CreateDatabase("test_" + std::to_string(databases++));
    return;
  }
  throw std::invalid_argument("unknown storage backend '" + backend + "'");
}

}  // namespace mapdelta::testing
