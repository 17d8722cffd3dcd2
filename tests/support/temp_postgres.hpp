#pragma once
// A throw-away PostgreSQL server for one test process: initdb into a fresh folder under /tmp,
// the postmaster started as a child of the test with a Unix socket in that folder (trust) and
// a free loopback port (password, SCRAM), stopped and removed by the destructor.
//
// How it ends when the test does not end normally:
//  - a failed gtest assertion returns from the test body: destructors run, the server stops;
//  - a crash, abort or ctest's timeout (SIGKILL) runs no destructor: the postmaster is started
//    with PR_SET_PDEATHSIG = SIGQUIT (PostgreSQL's immediate shutdown), so it goes down with
//    the test process (pg_ctl start would daemonize it and leave it running); the folder
//    left behind is removed by the next TempPostgres whose test process finds its owner dead.
// Keep the object on the main thread: the death signal follows the thread that forked.
//
// initdb and postgres refuse to run as root: when the test runs as root (CI), both run as
// `nobody`, which every Debian machine has, and the folder is given to that user.
#include <sys/types.h>

#include <filesystem>
#include <optional>
#include <string>

namespace mapdelta::testing {

class TempPostgres {
 public:
  // Throws std::runtime_error (with the server's log) if initdb or the start fails. Tests
  // run without fsync (they never survive a power loss); durable = true keeps PostgreSQL's
  // defaults (fsync, full-page writes), as benchmarks against SQLite's synchronous=FULL need.
  explicit TempPostgres(bool durable = false);
  ~TempPostgres();
  TempPostgres(const TempPostgres&) = delete;
  TempPostgres& operator=(const TempPostgres&) = delete;

  // The folder of the newest /usr/lib/postgresql/*/bin with initdb and postgres, or nullopt.
  static std::optional<std::filesystem::path> FindBinaries();

  // A new, empty database; returns its libpq URL over the Unix socket (trust, superuser).
  std::string CreateDatabase(const std::string& name);
  // The URL of a database over TCP on 127.0.0.1 with the superuser's password (or another).
  std::string TcpUrl(const std::string& database, const std::string& password) const;
  std::string SocketUrl(const std::string& database) const;
  const std::string& password() const { return password_; }
  int port() const { return port_; }
  pid_t pid() const { return pid_; }

 private:
  void InitDb(const std::filesystem::path& bin);
  void Start(const std::filesystem::path& bin, bool durable);
  void WaitUntilReady();
  void Stop();
  std::string LogTail() const;

  std::filesystem::path dir_;
  std::string password_;
  int port_ = 0;
  pid_t pid_ = -1;
  pid_t owner_ = -1;  // a forked child's copy (exit handlers run there too) leaves it alone
};

}  // namespace mapdelta::testing
