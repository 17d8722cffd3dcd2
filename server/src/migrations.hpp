#pragma once
// The numbered SQL files of migrations/, embedded at build time (CMake generates the .cpp with
// embed_migrations.cmake). Which of them a database still needs is schema_migrator.hpp's job.
#include <string_view>
#include <vector>

namespace mapdelta::server {

struct Migration {
  int version;
  std::string_view name;
  std::string_view sql;
};

const std::vector<Migration>& EmbeddedMigrations();          // sorted by version
const std::vector<Migration>& EmbeddedPostgresMigrations();  // migrations/postgres

}  // namespace mapdelta::server
