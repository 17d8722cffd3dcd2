// The PostgreSQL backend's foundations against a real server started by the test
// (tests/support/temp_postgres.hpp): the throw-away server itself (it goes down with a killed
// test process), the libpq wrapper (exact round trips, checked types, errors, one-line
// connection errors without the password) and its pool, both backends' migrations reaching the
// same schema, and one-line start errors (unreachable, wrong password, schema newer than the
// binary) in the library and from the real binary.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <thread>
#include <vector>

#include "mapdelta/common/error.hpp"
#include "mapdelta/server/storage.hpp"
#include "pg_db.hpp"
#include "pg_pool.hpp"
#include "server_backends.hpp"
#include "sqlite_db.hpp"
#include "support/temp_dir.hpp"
#include "temp_postgres.hpp"

namespace mapdelta::server {
namespace {

using mapdelta::testing::TempPostgres;
namespace fs = std::filesystem;

// One server per test process (ctest runs each test in its own process).
TempPostgres& Server() { return mapdelta::testing::SharedPostgres(); }

bool ProcessGone(pid_t pid) {
  // A zombie nobody reaps still answers kill(0): count state Z as gone.
  if (::kill(pid, 0) != 0) return true;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string pid_field, name, state;
  stat >> pid_field >> name >> state;
  return state == "Z" || state.empty();
}

TEST(TempPostgres, ServesSocketAndPasswordLoginAndStopsClean) {
  fs::path data;
  pid_t pid = -1;
  {
    TempPostgres server;
    pid = server.pid();
    const std::string url = server.CreateDatabase("helper");
    pg::Connection socket(url);
    EXPECT_EQ(socket.Query("SELECT current_database()::text").Text(0, 0), "helper");
    pg::Connection tcp(server.TcpUrl("helper", server.password()));
    EXPECT_EQ(tcp.Query("SELECT 41 + 1").Int(0, 0), 42);
    EXPECT_THROW(pg::Connection(server.TcpUrl("helper", "not-the-password")), Error);
    data = fs::path(socket.Query("SHOW data_directory").Text(0, 0));
    EXPECT_TRUE(fs::exists(data));
  }
  EXPECT_TRUE(ProcessGone(pid));
  EXPECT_FALSE(fs::exists(data.parent_path())) << data;
}

TEST(TempPostgres, GoesDownWithAKilledTestProcess) {
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // The "test process": starts a server, reports its pid, then waits to be killed.
    ::close(fds[0]);
    TempPostgres server;
    const pid_t pid = server.pid();
    if (::write(fds[1], &pid, sizeof(pid)) != sizeof(pid)) ::_exit(1);
    ::pause();
    ::_exit(0);
  }
  ::close(fds[1]);
  pid_t postmaster = -1;
  ASSERT_EQ(::read(fds[0], &postmaster, sizeof(postmaster)),
            static_cast<ssize_t>(sizeof(postmaster)));
  ::close(fds[0]);
  ASSERT_FALSE(ProcessGone(postmaster));
  ::kill(child, SIGKILL);  // as ctest's timeout does: no destructor runs
  ::waitpid(child, nullptr, 0);
  for (int i = 0; i < 200 && !ProcessGone(postmaster); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_TRUE(ProcessGone(postmaster)) << "postmaster " << postmaster << " outlived its test";
}

TEST(PgDb, RoundTripsValuesExactlyAndChecksTypes) {
  pg::Connection c(Server().CreateDatabase("roundtrip"));
  c.Exec("CREATE TABLE t (i BIGINT, r DOUBLE PRECISION, s TEXT, b BYTEA, n TEXT)");
  std::vector<uint8_t> all_bytes(256);
  for (int i = 0; i < 256; ++i) all_bytes[i] = static_cast<uint8_t>(i);
  const std::array<double, 5> reals = {0.1, -0.0, 1e300, 4.9e-324, -123456.789012345678};
  const std::array<int64_t, 5> ints = {std::numeric_limits<int64_t>::min(), -1, 0,
                                       std::numeric_limits<int64_t>::max(), 1234567890123};
  const std::string text = "it's \"quoted\", \\ back, ünïcode, 日本";
  for (size_t k = 0; k < reals.size(); ++k) {
    c.Query("INSERT INTO t VALUES ($1, $2, $3, $4, $5)",
            pg::Params().Add(ints[k]).Add(reals[k]).Add(text).Add(all_bytes).AddNull());
  }
  const pg::Result r = c.Query("SELECT i, r, s, b, n FROM t");
  ASSERT_EQ(r.rows(), 5);
  for (int k = 0; k < 5; ++k) {
    EXPECT_EQ(r.Int(k, 0), ints[k]);
    EXPECT_EQ(std::bit_cast<uint64_t>(r.Real(k, 1)), std::bit_cast<uint64_t>(reals[k])) << k;
    EXPECT_EQ(r.Text(k, 2), text);
    EXPECT_EQ(r.Bytes(k, 3), all_bytes);
    EXPECT_TRUE(r.IsNull(k, 4));
    EXPECT_FALSE(r.OptText(k, 4).has_value());
  }
  EXPECT_EQ(c.Query("UPDATE t SET n = 'x' WHERE i < 0").affected(), 2);
  // A column read as the wrong type is an error, not a conversion.
  try {
    r.Int(0, 2);
    FAIL() << "text read as integer";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInternal);
  }
  EXPECT_THROW(r.Text(0, 3), Error);
}

TEST(PgDb, ConstraintsAreConflictsAndTransactionsRollBack) {
  pg::Connection c(Server().CreateDatabase("errors"));
  c.Exec("CREATE TABLE u (k TEXT PRIMARY KEY)");
  c.Query("INSERT INTO u VALUES ($1)", pg::Params().Add("a"));
  try {
    c.Query("INSERT INTO u VALUES ($1)", pg::Params().Add("a"));
    FAIL() << "duplicate key accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kConflict);
    EXPECT_NE(std::string(e.what()).find("23505"), std::string::npos) << e.what();
  }
  try {
    c.Query("SELEC nonsense");
    FAIL() << "syntax error accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kIo);
    EXPECT_NE(std::string(e.what()).find("SELEC nonsense"), std::string::npos) << e.what();
  }
  {
    pg::Transaction tx(c);
    c.Query("INSERT INTO u VALUES ($1)", pg::Params().Add("b"));
  }  // no Commit: rolled back
  EXPECT_EQ(c.Query("SELECT COUNT(*) FROM u").Int(0, 0), 1);
  EXPECT_TRUE(c.reusable());
}

TEST(PgDb, ConnectionErrorsAreOneLineWithoutThePassword) {
  TempPostgres& server = Server();
  server.CreateDatabase("login");
  const std::string secret = server.password();
  auto message = [](const std::string& url) {
    try {
      pg::Connection c(url);
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kIo);
      return std::string(e.what());
    }
    ADD_FAILURE() << "connected to " << url;
    return std::string();
  };
  // Unreachable: port 1 on loopback (privileged, nothing listens there).
  std::string m =
      message("postgresql://mapdelta:" + secret + "@127.0.0.1:1/login?connect_timeout=5");
  EXPECT_EQ(m.rfind("cannot connect to PostgreSQL (", 0), 0u) << m;
  EXPECT_NE(m.find("refused"), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  EXPECT_EQ(m.find(secret), std::string::npos) << m;
  m = message(server.TcpUrl("login", "wrong-" + secret));
  EXPECT_NE(m.find("password authentication failed"), std::string::npos) << m;
  EXPECT_NE(m.find("dbname=login"), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  EXPECT_EQ(m.find("wrong-" + secret), std::string::npos) << m;
  EXPECT_EQ(pg::RedactConninfo("host=h password=p user=u"), "user=u host=h");
}

TEST(PgPool, HandsOutAtMostItsSizeAndDropsConnectionsLeftInATransaction) {
  pg::Pool pool(Server().CreateDatabase("pool"), 2);
  std::atomic<bool> third{false};
  std::thread waiter;
  {
    auto a = pool.Acquire();
    auto b = pool.Acquire();
    waiter = std::thread([&] {
      auto c = pool.Acquire();  // blocks until a or b is back
      third = true;
      EXPECT_TRUE(c->reusable());
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    EXPECT_FALSE(third) << "a third connection from a pool of two";
    a->Exec("BEGIN");  // handed back inside a transaction: dropped, not reused
  }
  waiter.join();
  EXPECT_TRUE(third);
  auto a = pool.Acquire();
  auto b = pool.Acquire();
  for (pg::Connection* c : {&*a, &*b}) {
    EXPECT_TRUE(c->reusable());
    EXPECT_EQ(c->Query("SELECT 1").Int(0, 0), 1);
  }
}

// table -> column names, from each backend's catalogue.
using Schema = std::map<std::string, std::set<std::string>>;

Schema SqliteSchema(const std::string& path) {
  sql::Db db(path);
  Schema schema;
  sql::Stmt tables(db, "SELECT name FROM sqlite_master WHERE type = 'table'");
  while (tables.Step()) {
    const std::string table = tables.Text(0);
    sql::Stmt cols(db, "SELECT name FROM pragma_table_info(?)");
    cols.Bind(1, table);
    while (cols.Step()) schema[table].insert(cols.Text(0));
  }
  return schema;
}

Schema PostgresSchema(pg::Connection& c) {
  Schema schema;
  const pg::Result r = c.Query(
      "SELECT table_name::text, column_name::text FROM information_schema.columns "
      "WHERE table_schema = 'public'");
  for (int i = 0; i < r.rows(); ++i) schema[r.Text(i, 0)].insert(r.Text(i, 1));
  return schema;
}

TEST(PostgresMigrations, ReachTheSameVersionTablesAndColumnsAsSqlite) {
  const fs::path dir = mapdelta::testing::FreshTempDir("mds_pg_schema");
  const std::string sqlite_path = (dir / "db.sqlite").string();
  OpenSqliteStorage(sqlite_path);
  const std::string url = Server().CreateDatabase("schema");
  OpenPostgresStorage(url, 2);
  OpenPostgresStorage(url, 2);  // a second start finds nothing to do
  pg::Connection c(url);
  // The same applied versions on both (numbers may have gaps: a number taken by a branch that
  // has not landed yet), the last one the binary's.
  const pg::Result versions = c.Query("SELECT version FROM schema_migrations ORDER BY version");
  std::vector<int64_t> pg_versions, sqlite_versions;
  for (int i = 0; i < versions.rows(); ++i) pg_versions.push_back(versions.Int(i, 0));
  ASSERT_FALSE(pg_versions.empty());
  EXPECT_EQ(pg_versions.back(), KnownSchemaVersion());
  sql::Db sqlite(sqlite_path);
  sql::Stmt v(sqlite, "SELECT version FROM schema_migrations ORDER BY version");
  while (v.Step()) sqlite_versions.push_back(v.Int(0));
  EXPECT_EQ(pg_versions, sqlite_versions);
  const Schema expected = SqliteSchema(sqlite_path);
  EXPECT_GE(expected.size(), 14u);
  EXPECT_EQ(PostgresSchema(c), expected);
  fs::remove_all(dir);
}

TEST(PostgresLeases, TwoWorkersShareTheQueueAndATakenOverJobRefusesItsOldWorker) {
  const std::string url = Server().CreateDatabase("leases");
  auto a = OpenPostgresStorage(url, 2);  // two processes' storages on one database
  auto b = OpenPostgresStorage(url, 2);
  ASSERT_NE(a->jobs().worker_id(), b->jobs().worker_id());
  const int64_t first = a->jobs().Create(JobType::kRefresh, "{}", 1);
  const int64_t second = a->jobs().Create(JobType::kRefresh, "{}", 1);
  ASSERT_EQ(a->jobs().ClaimNext(10, 100)->id, first);
  ASSERT_EQ(b->jobs().ClaimNext(11, 100)->id, second);  // first is a's
  EXPECT_FALSE(b->jobs().ClaimNext(12, 100));
  // A process starting now leaves running jobs with live leases alone (SQLite takes them all).
  EXPECT_EQ(b->jobs().RequeueInterrupted(50), 0);
  EXPECT_EQ(a->jobs().Get(first)->state, JobState::kRunning);
  // a stalls past its lease: b takes the job over.
  EXPECT_TRUE(b->jobs().RenewLease(second, 150, 1000));
  const auto taken = b->jobs().ClaimNext(200, 100);
  ASSERT_TRUE(taken);
  EXPECT_EQ(taken->id, first);
  EXPECT_EQ(taken->attempts, 2);
  EXPECT_EQ(taken->lease_owner, b->jobs().worker_id());
  EXPECT_FALSE(a->jobs().RenewLease(first, 201, 100));
  // a's late writes are refused whole, and its late finish changes nothing.
  TileStateRecord state;
  state.tile = TileId(0, 0);
  state.aggregate = {1, 2, 3};
  try {
    a->tiles().ApplyUpdates(first, {state}, 202);
    ADD_FAILURE() << "the old worker wrote tiles of a job taken over";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kConflict) << e.what();
  }
  EXPECT_FALSE(b->tiles().GetState(TileId(0, 0)));
  EXPECT_TRUE(b->jobs().TilesDone(first).empty());
  a->jobs().Finish(first, JobState::kFailed, "stale", std::nullopt, 203);
  EXPECT_EQ(b->jobs().Get(first)->state, JobState::kRunning);
  b->tiles().ApplyUpdates(first, {state}, 204);  // its owner writes
  EXPECT_TRUE(a->tiles().GetState(TileId(0, 0)));
  b->jobs().Finish(first, JobState::kSucceeded, "done", std::nullopt, 205);
  EXPECT_EQ(a->jobs().Get(first)->state, JobState::kSucceeded);
}

// The message of the Error a call throws ("" if none).
template <typename F>
std::string ErrorOf(F&& f, ErrorCode expected_code) {
  try {
    f();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), expected_code) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "no error";
  return "";
}

TEST(PostgresStart, UnreachableWrongPasswordAndNewerSchemaAreOneLineErrors) {
  TempPostgres& server = Server();
  const std::string url = server.CreateDatabase("start");
  const std::string secret = server.password();
  // Unreachable: port 1 on loopback (privileged, nothing listens there).
  const std::string closed =
      "postgresql://mapdelta:" + secret + "@127.0.0.1:1/start?connect_timeout=5";
  std::string m = ErrorOf([&] { OpenPostgresStorage(closed, 1); }, ErrorCode::kIo);
  EXPECT_NE(m.find("cannot connect to PostgreSQL"), std::string::npos) << m;
  EXPECT_NE(m.find("refused"), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  EXPECT_EQ(m.find(secret), std::string::npos) << m;

  m = ErrorOf([&] { OpenPostgresStorage(server.TcpUrl("start", "wrong-" + secret), 1); },
              ErrorCode::kIo);
  EXPECT_NE(m.find("password authentication failed"), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  EXPECT_EQ(m.find("wrong-" + secret), std::string::npos) << m;

  OpenPostgresStorage(server.TcpUrl("start", secret), 1);  // the right password migrates
  pg::Connection c(url);
  c.Query("INSERT INTO schema_migrations VALUES ($1, 'from_the_future', 0)",
          pg::Params().Add(int64_t{KnownSchemaVersion() + 1}));
  m = ErrorOf([&] { OpenPostgresStorage(url, 1); }, ErrorCode::kUnsupported);
  EXPECT_NE(m.find("newer than this server knows"), std::string::npos) << m;
}

// Runs the real binary; returns its exit code and stderr.
std::pair<int, std::string> RunServer(const std::string& config_yaml, const fs::path& dir) {
  const fs::path config = dir / "server.yaml";
  std::ofstream(config) << config_yaml;
  const std::string cmd = std::string(MAPDELTA_SERVER_BIN) + " serve --config " + config.string() +
                          " --port 0 --web-root '' 2>" + (dir / "stderr.txt").string() +
                          " >/dev/null";
  const int status = std::system(cmd.c_str());
  std::ifstream in(dir / "stderr.txt");
  std::stringstream err;
  err << in.rdbuf();
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, err.str()};
}

TEST(PostgresStart, TheServerBinaryExitsWithOneClearLine) {
  TempPostgres& server = Server();
  server.CreateDatabase("binary");
  const fs::path dir = mapdelta::testing::FreshTempDir("mds_pg_binary");
  const std::string prefix =
      "log:\n  level: error\nstorage:\n  backend: postgres\n  postgres_url: ";
  for (const auto& [url, expected] : std::vector<std::pair<std::string, std::string>>{
           {"postgresql://mapdelta@127.0.0.1:1/binary?connect_timeout=5", "refused"},
           {server.TcpUrl("binary", "wrong"), "password authentication failed"}}) {
    const auto [code, err] = RunServer(prefix + "\"" + url + "\"\n", dir);
    EXPECT_EQ(code, 1) << err;
    // The CLI names the command first, like every error of mapdelta-server.
    EXPECT_EQ(err.rfind("mapdelta-server serve: error: cannot connect to PostgreSQL", 0), 0u)
        << err;
    EXPECT_NE(err.find(expected), std::string::npos) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  }
  // A config naming the backend without a URL is a config error (exit 2), before any connect.
  const auto [code, err] = RunServer("storage:\n  backend: postgres\n", dir);
  EXPECT_EQ(code, 2) << err;
  EXPECT_NE(err.find("storage.postgres_url: must be set"), std::string::npos) << err;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mapdelta::server
