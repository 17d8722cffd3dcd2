// mapdelta-server: the map-update server and its admin commands.
#include <signal.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <filesystem>
#include <iostream>
#include <thread>

#include "auth.hpp"
#include "instance_lock.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/config.hpp"
#include "mapdelta/server/http_server.hpp"
#include "mapdelta/server/map_service.hpp"

namespace md = mapdelta;
namespace mds = mapdelta::server;

namespace {

constexpr const char* kUsage = R"(mapdelta-server: crowdsourced point-cloud map-update server (REST, SQLite).

Usage:
  mapdelta-server serve        --config FILE [--port N] [--web-root DIR]
  mapdelta-server token create --config FILE --role vehicle|reader|admin --name NAME
  mapdelta-server token revoke --config FILE --id TOKEN_ID
  mapdelta-server token list   --config FILE
  mapdelta-server import-prior --config FILE --cloud FILE.pcd|.ply [--note TEXT]
  mapdelta-server check-config --config FILE
  mapdelta-server --help

serve         Runs the HTTP API (see /v1/openapi.yaml). Prints "listening on HOST:PORT" to
              stdout once ready. SIGTERM/SIGINT: stop accepting, finish in-flight requests,
              pause the running job between tiles (it resumes at the next start), exit 0.
token create  Prints the new token's id and secret. The secret is shown only once; only
              its SHA-256 is stored.
token revoke  Revokes a token by id (requests with it get 401 from then on).
import-prior  Imports a PCD/PLY cloud as a new prior version (same as POST /v1/admin/prior).
check-config  Validates the config (all problems at once) and prints the effective config.

--port N overrides http.port (0 picks a free port). --web-root DIR serves the web map's
static files at / (default: the built web/dist; "" turns it off). Exit codes: 0 ok,
1 runtime error, 2 usage or config error.
)";

struct Args {
  bool help = false;
  std::vector<std::string> positional;
  std::map<std::string, std::string> options;
};

Args ParseArgs(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    std::string s = argv[i];
    if (s == "--help" || s == "-h") {
      a.help = true;
    } else if (s.rfind("--", 0) == 0) {
      if (i + 1 >= argc) {
        std::string message = "option ";  // built in steps: GCC 12 warns falsely on "x" + s
        message += s;
        message += " needs a value";
        throw md::Error(md::ErrorCode::kInvalidArgument, message);
      }
      const std::string value(argv[++i]);
      a.options.insert_or_assign(s.substr(2), value);
    } else {
      a.positional.push_back(s);
    }
  }
  return a;
}

std::string Required(const Args& a, const std::string& name) {
  auto it = a.options.find(name);
  if (it == a.options.end()) throw md::Error(md::ErrorCode::kInvalidArgument, "missing --" + name);
  return it->second;
}

void CheckKnown(const Args& a, std::initializer_list<const char*> known) {
  for (const auto& [k, v] : a.options) {
    if (std::find_if(known.begin(), known.end(), [&](const char* n) { return k == n; }) == known.end()) {
      throw md::Error(md::ErrorCode::kInvalidArgument, "unknown option --" + k);
    }
  }
}

// Log lines as JSON objects (one per line) or plain text, on stderr.
void InstallLogSink(const mds::LogConfig& c) {
  md::log::Level level = md::log::Level::kInfo;
  md::log::ParseLevel(c.level, &level);
  md::log::SetLevel(level);
  if (c.format != "json") return;
  md::log::SetSink([](md::log::Level lvl, const std::string& message) {
    static const char* kNames[] = {"debug", "info", "warn", "error", "off"};
    const mds::Json line{{"ts", mds::NowMs()}, {"level", kNames[static_cast<int>(lvl)]}, {"msg", message}};
    std::fprintf(stderr, "%s\n", line.dump(-1, ' ', false, mds::Json::error_handler_t::replace).c_str());
  });
}

int Serve(const Args& a) {
  CheckKnown(a, {"config", "port", "web-root"});
  mds::ServerConfig config = mds::LoadServerConfig(Required(a, "config"));
  if (a.options.count("port")) config.http.port = std::stoi(a.options.at("port"));
  InstallLogSink(config.log);
  MD_LOG(kInfo, "effective config:\n" << mds::DumpServerConfig(config));

  // One serving process per database: a second one would run a second job worker on the same
  // jobs. Held until Serve returns (or the kernel drops it when the process dies).
  const std::string lock_path = mds::InstanceLock::PathFor(config.storage.database);
  std::string holder;
  const auto instance_lock = mds::InstanceLock::TryAcquire(lock_path, &holder);
  if (!instance_lock) {
    throw md::Error(md::ErrorCode::kConflict,
                    "database " + config.storage.database +
                        " is already served by another mapdelta-server (pid " + holder + ", lock " +
                        lock_path + "); stop that one or set another storage.database");
  }

  // Block the stop signals in every thread; one thread waits for them with sigwait.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  mds::MapService service(config, mds::OpenSqliteStorage(config.storage.database));
  mds::HttpServer http(service);
  const std::string web_root = a.options.count("web-root") ? a.options.at("web-root") : MAPDELTA_WEB_ROOT;
  if (!web_root.empty() && !http.MountWebRoot(web_root)) {
    MD_LOG(kWarn, "web map not served: " << web_root << " is not a directory (tools/build-web.sh builds it)");
  }
  const int port = http.Bind(config.http.listen_address, config.http.port);
  service.StartJobWorker();
  std::thread waiter([&] {
    int sig = 0;
    sigwait(&signals, &sig);
    MD_LOG(kInfo, "signal " << sig << " received: shutting down");
    service.StopJobWorker();  // first: the running job pauses between tiles
    http.Stop();
  });
  std::printf("listening on %s:%d\n", config.http.listen_address.c_str(), port);
  std::fflush(stdout);
  MD_LOG(kInfo, "listening on " << config.http.listen_address << ":" << port);
  http.Run();
  if (waiter.joinable()) {
    // Run() only returns after Stop(), i.e. after a signal; the waiter is done or finishing.
    waiter.join();
  }
  MD_LOG(kInfo, "stopped cleanly");
  return 0;
}

int Token(const Args& a) {
  if (a.positional.size() < 2) throw md::Error(md::ErrorCode::kInvalidArgument, "token needs create, revoke or list");
  const std::string verb = a.positional[1];
  mds::ServerConfig config = mds::LoadServerConfig(Required(a, "config"));
  InstallLogSink(mds::LogConfig{"warn", "text"});
  auto storage = mds::OpenSqliteStorage(config.storage.database);
  if (verb == "create") {
    CheckKnown(a, {"config", "role", "name"});
    const auto role = mds::ParseRole(Required(a, "role"));
    if (!role) throw md::Error(md::ErrorCode::kInvalidArgument, "--role must be vehicle, reader or admin");
    const auto t = mds::CreateToken(*storage, Required(a, "name"), *role, mds::NowMs());
    std::printf("id: %s\nrole: %s\nname: %s\ntoken: %s\n", t.record.id.c_str(),
                std::string(mds::ToString(*role)).c_str(), t.record.name.c_str(), t.secret.c_str());
    return 0;
  }
  if (verb == "revoke") {
    CheckKnown(a, {"config", "id"});
    const std::string id = Required(a, "id");
    if (!storage->RevokeToken(id, mds::NowMs())) {
      throw md::Error(md::ErrorCode::kNotFound, "no active token with id " + id);
    }
    std::printf("revoked %s\n", id.c_str());
    return 0;
  }
  if (verb == "list") {
    CheckKnown(a, {"config"});
    for (const auto& t : storage->ListTokens()) {
      std::printf("%s  %-7s  %-8s  %s\n", t.id.c_str(), std::string(mds::ToString(t.role)).c_str(),
                  t.revoked_ms ? "revoked" : "active", t.name.c_str());
    }
    return 0;
  }
  throw md::Error(md::ErrorCode::kInvalidArgument, "unknown token command '" + verb + "'");
}

int ImportPrior(const Args& a) {
  CheckKnown(a, {"config", "cloud", "note"});
  mds::ServerConfig config = mds::LoadServerConfig(Required(a, "config"));
  InstallLogSink(mds::LogConfig{"info", "text"});
  mds::MapService service(config, mds::OpenSqliteStorage(config.storage.database));
  const std::string path = Required(a, "cloud");
  std::fprintf(stderr, "importing %s ...\n", path.c_str());
  const auto note = a.options.count("note") ? a.options.at("note") : std::filesystem::path(path).filename().string();
  std::printf("%s\n", service.ImportPriorFile(path, note).dump(2).c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  try {
    args = ParseArgs(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n\n%s", e.what(), kUsage);
    return 2;
  }
  if (args.help || args.positional.empty()) {
    std::printf("%s", kUsage);
    return args.help ? 0 : 2;
  }
  const std::string& command = args.positional[0];
  try {
    if (command == "serve") return Serve(args);
    if (command == "token") return Token(args);
    if (command == "import-prior") return ImportPrior(args);
    if (command == "check-config") {
      CheckKnown(args, {"config"});
      std::printf("%s\n", mds::DumpServerConfig(mds::LoadServerConfig(Required(args, "config"))).c_str());
      return 0;
    }
    std::fprintf(stderr, "error: unknown command '%s'\n\n%s", command.c_str(), kUsage);
    return 2;
  } catch (const mds::ApiError& e) {
    std::fprintf(stderr, "error: %s: %s\n", std::string(mds::Info(e.code()).name).c_str(), e.what());
    return 1;
  } catch (const md::Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    const bool usage = e.code() == md::ErrorCode::kInvalidArgument || e.code() == md::ErrorCode::kParse;
    return usage ? 2 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
