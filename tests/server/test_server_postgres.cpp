// The PostgreSQL foundations against a real server started by the test
// (tests/support/temp_postgres.hpp): the throw-away server itself (it goes down with a killed
// test process), and the libpq wrapper: exact round trips, checked types, errors, one-line
// connection errors without the password.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <bit>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <limits>
#include <thread>

#include "mapdelta/common/error.hpp"
#include "pg_db.hpp"
#include "pg_pool.hpp"
#include "temp_postgres.hpp"

namespace mapdelta::server {
namespace {

using mapdelta::testing::TempPostgres;
namespace fs = std::filesystem;

// One server per test process (ctest runs each test in its own process).
TempPostgres& Server() {
  static TempPostgres server;
  return server;
}

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

}  // namespace
}  // namespace mapdelta::server
