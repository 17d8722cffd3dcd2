// SQLite storage: opening and migrating the database, and the token store. The other stores
// are in storage_sqlite_{priors,sessions,jobs,tiles}.cpp.
#include "storage_sqlite.hpp"

#include "schema_migrator.hpp"

namespace mapdelta::server {

namespace {

// Runs inside the transaction OpenSqliteStorage opened.
class SqliteSchemaTarget final : public SchemaTarget {
 public:
  explicit SqliteSchemaTarget(sql::Db& db) : db_(db) {}
  int64_t AppliedVersion() override {
    db_.Exec(
        "CREATE TABLE IF NOT EXISTS schema_migrations (version INTEGER PRIMARY KEY, "
        "name TEXT NOT NULL, applied_ms INTEGER NOT NULL)");
    sql::Stmt s(db_, "SELECT COALESCE(MAX(version), 0) FROM schema_migrations");
    return s.Step() ? s.Int(0) : 0;
  }
  void Apply(const Migration& m) override {
    db_.Exec(m.sql);
    sql::Stmt s(db_, "INSERT INTO schema_migrations VALUES (?, ?, strftime('%s','now')*1000)");
    s.Bind(1, int64_t{m.version}).Bind(2, m.name).Run();
  }

 private:
  sql::Db& db_;
};

}  // namespace

std::unique_ptr<Storage> OpenSqliteStorage(const std::string& path) {
  auto connection = std::make_shared<SqliteConnection>(path);
  {
    sql::Transaction tx(connection->db);
    SqliteSchemaTarget target(connection->db);
    MigrateSchema(target, EmbeddedMigrations());
    tx.Commit();
  }
  Storage::Stores stores;
  stores.tokens = std::make_unique<SqliteTokenStore>(connection);
  stores.priors = std::make_unique<SqlitePriorStore>(connection);
  stores.sessions = std::make_unique<SqliteSessionStore>(connection);
  stores.jobs = std::make_unique<SqliteJobStore>(connection);
  stores.tiles = std::make_unique<SqliteTileStore>(connection);
  stores.clusters = std::make_unique<SqliteClusterStore>(connection);
  stores.coverage = std::make_unique<SqliteCoverageStore>(connection);
  return std::make_unique<Storage>(std::move(stores));
}

void BindTileRange(sql::Stmt& s, int first, const Rect& r) {
  s.Bind(first, static_cast<int64_t>(r.min_x))
      .Bind(first + 1, static_cast<int64_t>(r.max_x))
      .Bind(first + 2, static_cast<int64_t>(r.min_y))
      .Bind(first + 3, static_cast<int64_t>(r.max_y));
}

// ---------------------------------------------------------------- tokens

void SqliteTokenStore::Insert(const TokenRecord& t, const std::string& hash) {
  auto lock = Lock();
  sql::Stmt s(db(), "INSERT INTO tokens (id, name, role, hash, created_ms) VALUES (?,?,?,?,?)");
  s.Bind(1, t.id).Bind(2, t.name).Bind(3, ToString(t.role)).Bind(4, hash).Bind(5, t.created_ms);
  s.Run();
}

namespace {
TokenRecord ReadToken(sql::Stmt& s) {
  TokenRecord t;
  t.id = s.Text(0);
  t.name = s.Text(1);
  t.role = ParseEnumOrThrow<Role>(s.Text(2), "tokens.role");
  t.created_ms = s.Int(3);
  if (!s.IsNull(4)) t.revoked_ms = s.Int(4);
  return t;
}
}  // namespace

std::optional<TokenRecord> SqliteTokenStore::FindActiveByHash(const std::string& hash) {
  auto lock = Lock();
  sql::Stmt s(db(),
              "SELECT id, name, role, created_ms, revoked_ms FROM tokens "
              "WHERE hash = ? AND revoked_ms IS NULL");
  s.Bind(1, hash);
  if (!s.Step()) return std::nullopt;
  return ReadToken(s);
}

bool SqliteTokenStore::Revoke(const std::string& id, int64_t now_ms) {
  auto lock = Lock();
  sql::Stmt s(db(), "UPDATE tokens SET revoked_ms = ? WHERE id = ? AND revoked_ms IS NULL");
  s.Bind(1, now_ms).Bind(2, id).Run();
  return db().Changes() > 0;
}

std::vector<TokenRecord> SqliteTokenStore::List() {
  auto lock = Lock();
  sql::Stmt s(db(),
              "SELECT id, name, role, created_ms, revoked_ms FROM tokens ORDER BY created_ms");
  std::vector<TokenRecord> out;
  while (s.Step()) out.push_back(ReadToken(s));
  return out;
}

}  // namespace mapdelta::server
