#include "storage_backends.hpp"

#include "mapdelta/server/memory_storage.hpp"
#include "server_backends.hpp"

namespace mapdelta::server::testing {

std::vector<StorageBackend> StorageBackends() {
  return {
      {"Sqlite",
       [](const std::filesystem::path& scratch) {
         return OpenSqliteStorage((scratch / "contract.sqlite").string());
       }},
      {"Memory", [](const std::filesystem::path&) { return OpenMemoryStorage(); }},
      {"Postgres",
       [](const std::filesystem::path&) {
         static int databases = 0;  // one server per test process, a database per storage
         const std::string url = mapdelta::testing::SharedPostgres().CreateDatabase(
             "contract_" + std::to_string(databases++));
         return OpenPostgresStorage(url, 4);
       }},
  };
}

}  // namespace mapdelta::server::testing
