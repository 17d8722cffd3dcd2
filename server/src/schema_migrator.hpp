#pragma once
// Which numbered migrations to apply, decided once for every backend: a backend only says
// which version its database is at and how to run one migration, inside the one transaction it
// opened around MigrateSchema (so a failed migration leaves the schema as it was).
#include <cstdint>
#include <string_view>
#include <vector>

#include "migrations.hpp"

namespace mapdelta::server {

class SchemaTarget {
 public:
  virtual ~SchemaTarget() = default;
  // The highest applied version, 0 for a fresh database (creates the record table if missing).
  virtual int64_t AppliedVersion() = 0;
  // Runs the migration's SQL and records its version and name.
  virtual void Apply(const Migration& migration) = 0;
};

// Highest version in a list sorted by version (0 if empty).
int NewestVersion(const std::vector<Migration>& migrations);

// Applies every migration newer than the target's version, in order; returns how many.
// Throws Error(kUnsupported) naming both versions if the database is newer than the list.
int MigrateSchema(SchemaTarget& target, const std::vector<Migration>& migrations);

}  // namespace mapdelta::server
