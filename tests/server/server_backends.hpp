#pragma once
// Runs a suite against every storage backend: `INSTANTIATE_TEST_SUITE_P(Backends, MyTest,
// ::testing::ValuesIn(mapdelta::testing::kServerBackends), BackendName)` and, in SetUp,
// UseFreshDatabase(GetParam(), dir, &config). PostgreSQL is a throw-away server shared by the
// test process (tests/support/temp_postgres.hpp), with a new database per call.
#include <filesystem>
#include <string>
#include <vector>

#include "mapdelta/server/config.hpp"
#include "temp_postgres.hpp"

namespace mapdelta::testing {

inline const std::vector<std::string> kServerBackends = {"sqlite", "postgres"};

// The test process's PostgreSQL server, started on first use, stopped at exit.
TempPostgres& SharedPostgres();

// Points config->storage at a new, empty database of the backend ("sqlite": a file in dir;
// "postgres": a new database on SharedPostgres()). Throws on an unknown backend.
void UseFreshDatabase(const std::string& backend, const std::filesystem::path& dir,
                      server::ServerConfig* config);

// Test-name suffix for a backend parameter.
struct BackendName {
  template <typename ParamInfo>
  std::string operator()(const ParamInfo& info) const {
    return info.param;
  }
};

}  // namespace mapdelta::testing
