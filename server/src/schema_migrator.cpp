#include "schema_migrator.hpp"

#include <string>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/storage.hpp"

namespace mapdelta::server {

int NewestVersion(const std::vector<Migration>& migrations) {
  return migrations.empty() ? 0 : migrations.back().version;
}

int KnownSchemaVersion() { return NewestVersion(EmbeddedMigrations()); }

int MigrateSchema(SchemaTarget& target, const std::vector<Migration>& migrations) {
  const int64_t current = target.AppliedVersion();
  const int newest = NewestVersion(migrations);
  if (current > newest) {
    throw Error(ErrorCode::kUnsupported, "database schema version " + std::to_string(current) +
                                             " is newer than this server knows (" +
                                             std::to_string(newest) + "); upgrade mapdelta-server");
  }
  int applied = 0;
  for (const Migration& m : migrations) {
    if (m.version <= current) continue;
    MD_LOG(kInfo, "applying migration " << m.name);
    target.Apply(m);
    ++applied;
  }
  return applied;
}

}  // namespace mapdelta::server
