#include "storage_backends.hpp"

#include "mapdelta/server/memory_storage.hpp"

namespace mapdelta::server::testing {

std::vector<StorageBackend> StorageBackends() {
  return {
      {"Sqlite",
       [](const std::filesystem::path& scratch) {
         return OpenSqliteStorage((scratch / "contract.sqlite").string());
       }},
      {"Memory", [](const std::filesystem::path&) { return OpenMemoryStorage(); }},
  };
}

}  // namespace mapdelta::server::testing
