#pragma once
// A storage that lives in this process's memory only: the same contract as the SQLite one
// (tests/server/test_storage_contract.cpp), for facade tests that need no database file.
#include <memory>

#include "mapdelta/server/storage.hpp"

namespace mapdelta::server {

std::unique_ptr<Storage> OpenMemoryStorage();

}  // namespace mapdelta::server
