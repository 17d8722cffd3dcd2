#include "temp_postgres.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <grp.h>
#include <libpq-fe.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

namespace mapdelta::testing {
namespace fs = std::filesystem;
namespace {

constexpr const char* kFolderPrefix = "mapdelta-pg-";
constexpr const char* kSuperuser = "mapdelta";
constexpr auto kStartTimeout = std::chrono::seconds(60);
constexpr auto kStopTimeout = std::chrono::seconds(30);

// The user initdb and postgres run as: ourselves, or `nobody` when we are root.
struct RunAs {
  bool switch_user = false;
  uid_t uid = 0;
  gid_t gid = 0;
};

RunAs UnprivilegedUser() {
  RunAs r;
  if (::geteuid() != 0) return r;
  const passwd* pw = ::getpwnam("nobody");
  if (!pw) throw std::runtime_error("TempPostgres: running as root and there is no user 'nobody'");
  r.switch_user = true;
  r.uid = pw->pw_uid;
  r.gid = pw->pw_gid;
  return r;
}

// fork + exec with stdout/stderr appended to log_path. Only async-signal-safe calls between
// fork and exec (everything is prepared before the fork).
pid_t Spawn(const std::vector<std::string>& args, const fs::path& cwd, const fs::path& log_path,
            const RunAs& as, bool die_with_parent) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const std::string log = log_path.string();
  const std::string dir = cwd.string();
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error("TempPostgres: fork failed");
  if (pid > 0) return pid;
  const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  if (fd >= 0) {
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    ::close(fd);
  }
  if (as.switch_user &&
      (::setgroups(0, nullptr) != 0 || ::setgid(as.gid) != 0 || ::setuid(as.uid) != 0)) {
    ::_exit(126);
  }
  // After the credential change: changing uid clears the parent-death signal.
  if (die_with_parent) {
    ::prctl(PR_SET_PDEATHSIG, SIGQUIT);
    if (::getppid() != parent) ::_exit(1);  // the parent died before prctl
  }
  // Our own working directory may be closed to `nobody` (e.g. /root).
  if (::chdir(dir.c_str()) != 0) ::_exit(125);
  ::execv(argv[0], argv.data());
  ::_exit(127);
}

// Waits up to timeout; returns the exit status, or nullopt if still running.
std::optional<int> WaitFor(pid_t pid, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (true) {
    int status = 0;
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) return status;
    if (r < 0) return -1;
    if (std::chrono::steady_clock::now() >= end) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

int FreeLoopbackPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof(addr);
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    if (fd >= 0) ::close(fd);
    throw std::runtime_error("TempPostgres: no free loopback port");
  }
  ::close(fd);
  return ntohs(addr.sin_port);
}

std::string RandomHex(int bytes) {
  std::random_device rd;
  std::ostringstream os;
  for (int i = 0; i < bytes; ++i) os << std::hex << ((rd() >> 4) & 0xf) << (rd() & 0xf);
  return os.str();
}

// Folders of earlier test processes that were killed (their pid is gone) are removed.
void RemoveStaleFolders(const fs::path& parent) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(parent, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(kFolderPrefix, 0) != 0) continue;
    const long pid =
        std::strtol(name.c_str() + std::char_traits<char>::length(kFolderPrefix), nullptr, 10);
    if (pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) {
      fs::remove_all(entry.path(), ec);
    }
  }
}

void Chown(const fs::path& p, const RunAs& as) {
  if (as.switch_user && ::chown(p.c_str(), as.uid, as.gid) != 0) {
    throw std::runtime_error("TempPostgres: cannot chown " + p.string());
  }
}

}  // namespace

std::optional<fs::path> TempPostgres::FindBinaries() {
  std::vector<fs::path> found;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/usr/lib/postgresql", ec)) {
    const fs::path bin = entry.path() / "bin";
    if (fs::exists(bin / "initdb") && fs::exists(bin / "postgres")) found.push_back(bin);
  }
  if (found.empty()) return std::nullopt;
  // Versions are folder names ("15", "16"): numeric order, newest last.
  std::sort(found.begin(), found.end(), [](const fs::path& a, const fs::path& b) {
    return std::stoi(a.parent_path().filename().string()) <
           std::stoi(b.parent_path().filename().string());
  });
  return found.back();
}

TempPostgres::TempPostgres(bool durable) : owner_(::getpid()) {
  const auto bin = FindBinaries();
  if (!bin)
    throw std::runtime_error(
        "TempPostgres: no /usr/lib/postgresql/*/bin/initdb (apt-get install postgresql)");
  // /tmp rather than $TMPDIR: the socket path must stay under 108 bytes.
  const fs::path parent = "/tmp";
  RemoveStaleFolders(parent);
  static int counter = 0;
  dir_ = parent / (kFolderPrefix + std::to_string(::getpid()) + "-" + std::to_string(counter++));
  fs::remove_all(dir_);
  fs::create_directories(dir_);
  password_ = RandomHex(12);
  try {
    InitDb(*bin);
    Start(*bin, durable);
    WaitUntilReady();
  } catch (...) {
    Stop();
    throw;
  }
}

TempPostgres::~TempPostgres() { Stop(); }

void TempPostgres::InitDb(const fs::path& bin) {
  const RunAs as = UnprivilegedUser();
  Chown(dir_, as);
  const fs::path pwfile = dir_ / "pwfile";
  std::ofstream(pwfile) << password_ << "\n";
  Chown(pwfile, as);
  const std::vector<std::string> args = {(bin / "initdb").string(),
                                         "-D",
                                         (dir_ / "data").string(),
                                         "-U",
                                         kSuperuser,
                                         "--pwfile=" + pwfile.string(),
                                         "--auth-local=trust",
                                         "--auth-host=scram-sha-256",
                                         "-E",
                                         "UTF8",
                                         "--locale=C",
                                         "--no-sync"};
  const pid_t pid = Spawn(args, dir_, dir_ / "initdb.log", as, /*die_with_parent=*/false);
  const auto status = WaitFor(pid, kStartTimeout);
  if (!status || !WIFEXITED(*status) || WEXITSTATUS(*status) != 0) {
    if (!status) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, nullptr, 0);
    }
    std::ifstream in(dir_ / "initdb.log");
    std::stringstream log;
    log << in.rdbuf();
    throw std::runtime_error("TempPostgres: initdb failed:\n" + log.str());
  }
}

void TempPostgres::Start(const fs::path& bin, bool durable) {
  const RunAs as = UnprivilegedUser();
  port_ = FreeLoopbackPort();
  // Enough connections for a few server processes with their pools and the test's own.
  std::vector<std::string> args = {(bin / "postgres").string(),
                                   "-D",
                                   (dir_ / "data").string(),
                                   "-k",
                                   dir_.string(),
                                   "-p",
                                   std::to_string(port_),
                                   "-c",
                                   "listen_addresses=127.0.0.1",
                                   "-c",
                                   "max_connections=200",
                                   "-c",
                                   "shared_buffers=64MB"};
  if (!durable) {
    for (const char* setting : {"fsync=off", "full_page_writes=off"}) {
      args.push_back("-c");
      args.push_back(setting);
    }
  }
  pid_ = Spawn(args, dir_, dir_ / "postgres.log", as, /*die_with_parent=*/true);
}

void TempPostgres::WaitUntilReady() {
  const std::string url = SocketUrl("postgres");
  const auto end = std::chrono::steady_clock::now() + kStartTimeout;
  while (std::chrono::steady_clock::now() < end) {
    if (WaitFor(pid_, std::chrono::milliseconds(0))) {
      pid_ = -1;
      throw std::runtime_error("TempPostgres: postgres exited at start:\n" + LogTail());
    }
    if (PQping(url.c_str()) == PQPING_OK) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  throw std::runtime_error("TempPostgres: postgres not ready after 60 s:\n" + LogTail());
}

void TempPostgres::Stop() {
  if (::getpid() != owner_) return;
  if (pid_ > 0) {
    // SIGINT = fast shutdown (what pg_ctl stop -m fast sends); SIGQUIT = immediate.
    ::kill(pid_, SIGINT);
    if (!WaitFor(pid_, kStopTimeout)) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    pid_ = -1;
  }
  std::error_code ec;
  if (!dir_.empty()) fs::remove_all(dir_, ec);
}

std::string TempPostgres::LogTail() const {
  std::ifstream in(dir_ / "postgres.log");
  std::stringstream log;
  log << in.rdbuf();
  const std::string s = log.str();
  return s.size() > 4000 ? s.substr(s.size() - 4000) : s;
}

std::string TempPostgres::SocketUrl(const std::string& database) const {
  return "host=" + dir_.string() + " port=" + std::to_string(port_) + " user=" + kSuperuser +
         " dbname=" + database;
}

std::string TempPostgres::TcpUrl(const std::string& database, const std::string& password) const {
  return "postgresql://" + std::string(kSuperuser) + ":" + password +
         "@127.0.0.1:" + std::to_string(port_) + "/" + database;
}

std::string TempPostgres::CreateDatabase(const std::string& name) {
  const bool ok = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
  });
  if (!ok) throw std::invalid_argument("TempPostgres: database names are [a-z0-9_]+: " + name);
  PGconn* conn = PQconnectdb(SocketUrl("postgres").c_str());
  std::string error;
  if (PQstatus(conn) != CONNECTION_OK) {
    error = PQerrorMessage(conn);
  } else {
    // Quoted: the checked name may still be an SQL keyword ("binary", "user").
    PGresult* r = PQexec(conn, ("CREATE DATABASE \"" + name + "\"").c_str());
    if (PQresultStatus(r) != PGRES_COMMAND_OK) error = PQresultErrorMessage(r);
    PQclear(r);
  }
  PQfinish(conn);
  if (!error.empty())
    throw std::runtime_error("TempPostgres: CREATE DATABASE " + name + ": " + error);
  return SocketUrl(name);
}

}  // namespace mapdelta::testing
