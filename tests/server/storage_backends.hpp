#pragma once
// The storage backends the contract suite (test_storage_contract.cpp) runs against. Adding a
// backend = one entry in StorageBackends() (storage_backends.cpp); see tests/README.md.
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "mapdelta/server/storage.hpp"

namespace mapdelta::server::testing {

struct StorageBackend {
  std::string name;  // the test-name suffix: letters, digits and '_' only
  // Opens a fresh, empty storage. scratch is an empty folder that lives until the storage is
  // destroyed (for a database file); a backend with a server of its own starts it once per
  // process and hands out a fresh database per call.
  std::function<std::unique_ptr<Storage>(const std::filesystem::path& scratch)> open;
};

std::vector<StorageBackend> StorageBackends();

}  // namespace mapdelta::server::testing
