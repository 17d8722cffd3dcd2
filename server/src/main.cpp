// mapdelta-server: the map-update server and its admin commands.
#include <signal.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <thread>

#include "auth.hpp"
#include "cmd_export_autoware.hpp"
#include "instance_lock.hpp"
#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/config.hpp"
#include "mapdelta/server/http_server.hpp"
#include "mapdelta/server/map_service.hpp"
#include "web_root.hpp"

namespace md = mapdelta;
namespace mds = mapdelta::server;
namespace cli = mapdelta::cli;

namespace {

constexpr const char* kUsage =
    R"(mapdelta-server: crowdsourced point-cloud map-update server (REST; SQLite or PostgreSQL).

Usage:
  mapdelta-server serve        --config FILE [--port N] [--web-root DIR] [--api-only | --worker-only]
  mapdelta-server token create --config FILE --role vehicle|reader|admin --name NAME
  mapdelta-server token revoke --config FILE --id TOKEN_ID
  mapdelta-server token list   --config FILE
  mapdelta-server import-prior --config FILE --cloud FILE.pcd|.ply|.las|DIR [--note TEXT]
                               [--origin X,Y,Z] [--crs NAME]
  mapdelta-server export-autoware --config FILE --version N --out DIR [--tile-size M]
  mapdelta-server check-config --config FILE
  mapdelta-server --help

serve         Runs the HTTP API (see /v1/openapi.yaml). Prints "listening on HOST:PORT" to
              stdout once ready. SIGTERM/SIGINT: stop accepting, finish in-flight requests,
              pause the running job between tiles (it resumes at the next start), exit 0.
              --api-only: the HTTP API without the job worker (jobs wait for a worker).
              --worker-only: the job worker without HTTP; prints "worker ready" once it
              runs. Several API and worker processes share one PostgreSQL database
              (storage.backend: postgres; deploy/SCALE-OUT.md).
token create  Prints the new token's id and secret. The secret is shown only once; only
              its SHA-256 is stored.
token revoke  Revokes a token by id (requests with it get 401 from then on).
import-prior  Imports a PCD, PLY or LAS cloud, or an Autoware grid map folder (tiles +
              pointcloud_map_metadata.yaml), as a new prior version (over HTTP:
              POST /v1/admin/prior, PCD/PLY). The first import sets the map's frame
              (--crs, --origin; printed); later ones must agree with it.
export-autoware  Writes a prior version as an Autoware grid map folder.
check-config  Validates the config (all problems at once) and prints the effective config.

Run 'mapdelta-server COMMAND --help' for a command's options. Exit codes: 0 success,
1 runtime failure or unreadable/malformed input, 2 usage or configuration error.
)";

// The options every command reads: the config file.
cli::Parser& AddConfigOption(cli::Parser& cli, std::string* path) {
  return cli
      .Option("config", path, "server configuration (YAML, see config/server.example.yaml)", "FILE")
      .Require({"config"});
}

// Log lines as JSON objects (one per line) or plain text, on stderr.
void InstallLogSink(const mds::LogConfig& c) {
  md::log::Level level = md::log::Level::kInfo;
  md::log::ParseLevel(c.level, &level);
  md::log::SetLevel(level);
  if (c.format != "json") return;
  md::log::SetSink([](md::log::Level lvl, const std::string& message) {
    static const char* kNames[] = {"debug", "info", "warn", "error", "off"};
    const mds::Json line{
        {"ts", mds::NowMs()}, {"level", kNames[static_cast<int>(lvl)]}, {"msg", message}};
    std::fprintf(stderr, "%s\n",
                 line.dump(-1, ' ', false, mds::Json::error_handler_t::replace).c_str());
  });
}

// Blocks the stop signals in every thread (call before any thread starts); WaitForStop
// then receives one of them.
sigset_t BlockStopSignals() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  return signals;
}

void WaitForStop(const sigset_t& signals) {
  int sig = 0;
  sigwait(&signals, &sig);
  MD_LOG(kInfo, "signal " << sig << " received: shutting down");
}

// One serving process per SQLite database: a second one would run a second job worker on the
// same jobs. Held until Serve returns (or the kernel drops it when the process dies). PostgreSQL
// is shared by design: its workers claim jobs with row locks and leases instead.
std::optional<mds::InstanceLock> LockSqliteDatabase(const mds::ServerConfig& config) {
  if (config.storage.backend != "sqlite") return std::nullopt;
  const std::string lock_path = mds::InstanceLock::PathFor(config.storage.database);
  std::string holder;
  auto instance_lock = mds::InstanceLock::TryAcquire(lock_path, &holder);
  if (!instance_lock) {
    throw md::Error(md::ErrorCode::kConflict,
                    "database " + config.storage.database +
                        " is already served by another mapdelta-server (pid " + holder + ", lock " +
                        lock_path + "); stop that one or set another storage.database");
  }
  return instance_lock;
}

// --worker-only: jobs, no HTTP.
int ServeWorker(mds::MapService& service, const sigset_t& signals) {
  service.StartJobWorker();
  std::printf("worker ready\n");
  std::fflush(stdout);
  MD_LOG(kInfo, "job worker running (no HTTP)");
  WaitForStop(signals);
  service.StopJobWorker();  // the running job pauses between tiles
  MD_LOG(kInfo, "stopped cleanly");
  return 0;
}

int Serve(const std::vector<std::string>& args) {
  std::string config_path, web_root;
  int port_override = 0;
  bool api_only = false, worker_only = false;
  cli::Parser cli(
      "mapdelta-server serve",
      "Runs the HTTP API (see /v1/openapi.yaml). Prints \"listening on HOST:PORT\" to stdout once\n"
      "ready. SIGTERM/SIGINT: stop accepting, finish in-flight requests, pause the running job\n"
      "between tiles (it resumes at the next start), exit 0.");
  AddConfigOption(cli, &config_path)
      .Option("port", &port_override, "overrides http.port (0 picks a free port)")
      .Option(
          "web-root", &web_root,
          "serves the web map's static files at / (overrides http.web_root; \"\" or off: no page)",
          "DIR")
      .Flag("api-only", &api_only, "HTTP API without a job worker (scale-out, PostgreSQL)")
      .Flag("worker-only", &worker_only,
            "job worker without HTTP; prints \"worker ready\" (scale-out, PostgreSQL)")
      .Footer(cli::kExitCodesFooter);
  if (!cli.Parse(args, std::cout)) return cli::kExitOk;
  if (cli.Given("port") && (port_override < 0 || port_override > 65535)) {
    cli::FailUsage(cli.program(),
                   "--port: expected 0..65535, got " + std::to_string(port_override));
  }
  if (api_only && worker_only) {
    cli::FailUsage(cli.program(), "--api-only and --worker-only exclude each other");
  }
  mds::ServerConfig config = mds::LoadServerConfig(config_path);
  if (cli.Given("port")) config.http.port = port_override;
  if (cli.Given("web-root")) config.http.web_root = web_root.empty() ? "off" : web_root;
  InstallLogSink(config.log);
  MD_LOG(kInfo, "effective config:\n" << mds::DumpServerConfig(config));
  const auto instance_lock = LockSqliteDatabase(config);

  const sigset_t signals = BlockStopSignals();
  mds::MapService service(config, mds::OpenConfiguredStorage(config));
  if (worker_only) return ServeWorker(service, signals);
  mds::HttpServer http(service);
  const std::string page = mds::ResolveWebRoot(config.http.web_root, mds::CurrentExecutablePath(),
                                               MAPDELTA_BUILD_DIR, MAPDELTA_SOURCE_WEB_DIST);
  if (!page.empty() && !http.MountWebRoot(page)) {
    MD_LOG(kWarn,
           "web map not served: " << page << " is not a directory (tools/build-web.sh builds it)");
  } else if (!page.empty()) {
    MD_LOG(kInfo, "web map served from " << page);
  }
  const int port = http.Bind(config.http.listen_address, config.http.port);
  if (!api_only) service.StartJobWorker();
  std::thread waiter([&] {
    WaitForStop(signals);
    service.StopJobWorker();  // first: the running job pauses between tiles
    http.Stop();
  });
  std::printf("listening on %s:%d\n", config.http.listen_address.c_str(), port);
  std::fflush(stdout);
  MD_LOG(kInfo, "listening on " << config.http.listen_address << ":" << port
                                << (api_only ? " (API only, no job worker)" : ""));
  http.Run();
  if (waiter.joinable()) {
    // Run() only returns after Stop(), i.e. after a signal; the waiter is done or finishing.
    waiter.join();
  }
  MD_LOG(kInfo, "stopped cleanly");
  return 0;
}

// The token commands' storage, opened with only warnings logged (their output is the answer).
auto OpenStorageForAdmin(const std::string& config_path) {
  const mds::ServerConfig config = mds::LoadServerConfig(config_path);
  InstallLogSink(mds::LogConfig{"warn", "text"});
  return mds::OpenConfiguredStorage(config);
}

int TokenCreate(const std::vector<std::string>& args) {
  std::string config_path, role_name, name;
  cli::Parser cli("mapdelta-server token create",
                  "Prints the new token's id and secret. The secret is shown only once; only its "
                  "SHA-256 is stored.");
  AddConfigOption(cli, &config_path)
      .Option("role", &role_name, "what the token may do")
      .Choices("role", {"vehicle", "reader", "admin"})
      .Option("name", &name, "who or what holds it", "NAME")
      .Require({"role", "name"})
      .Footer(cli::kExitCodesFooter);
  if (!cli.Parse(args, std::cout)) return cli::kExitOk;
  auto storage = OpenStorageForAdmin(config_path);
  const auto role = mds::ParseEnum<mds::Role>(role_name);  // one of the choices above
  const auto t = mds::CreateToken(*storage, name, *role, mds::NowMs());
  std::printf("id: %s\nrole: %s\nname: %s\ntoken: %s\n", t.record.id.c_str(),
              std::string(mds::ToString(*role)).c_str(), t.record.name.c_str(), t.secret.c_str());
  return 0;
}

int TokenRevoke(const std::vector<std::string>& args) {
  std::string config_path, id;
  cli::Parser cli("mapdelta-server token revoke",
                  "Revokes a token by id (requests with it get 401 from then on).");
  AddConfigOption(cli, &config_path)
      .Option("id", &id, "the token's id", "TOKEN_ID")
      .Require({"id"});
  cli.Footer(cli::kExitCodesFooter);
  if (!cli.Parse(args, std::cout)) return cli::kExitOk;
  auto storage = OpenStorageForAdmin(config_path);
  if (!storage->tokens().Revoke(id, mds::NowMs()))
    throw md::Error(md::ErrorCode::kNotFound, "no active token with id " + id);
  std::printf("revoked %s\n", id.c_str());
  return 0;
}

int TokenList(const std::vector<std::string>& args) {
  std::string config_path;
  cli::Parser cli("mapdelta-server token list",
                  "Lists every token: id, role, active or revoked, name.");
  AddConfigOption(cli, &config_path).Footer(cli::kExitCodesFooter);
  if (!cli.Parse(args, std::cout)) return cli::kExitOk;
  auto storage = OpenStorageForAdmin(config_path);
  for (const auto& t : storage->tokens().List()) {
    std::printf("%s  %-7s  %-8s  %s\n", t.id.c_str(), std::string(mds::ToString(t.role)).c_str(),
                t.revoked_ms ? "revoked" : "active", t.name.c_str());
  }
  return 0;
}

int ImportPrior(const std::vector<std::string>& args) {
  std::string config_path, path, note, origin_text, crs;
  cli::Parser cli("mapdelta-server import-prior",
                  "Imports a PCD, PLY or LAS cloud, or an Autoware grid map folder (tile PCDs\n"
                  "listed in its pointcloud_map_metadata.yaml, each point checked against its\n"
                  "tile's box, placed by its map_projector_info.yaml), as a new prior version\n"
                  "(over HTTP: POST /v1/admin/prior, PCD/PLY). The first import sets the map's\n"
                  "frame: --crs and --origin, or the folder's projector, or an origin chosen from\n"
                  "the cloud (printed); later imports must agree with it.");
  AddConfigOption(cli, &config_path)
      .Option("cloud", &path, "the prior map, in the map's coordinates (e.g. UTM)",
              "FILE.pcd|.ply|.las|DIR")
      .Option("note", &note, "recorded with the version (default: the file name)", "TEXT")
      .Option("origin", &origin_text,
              "the map's local origin in those coordinates (first import; points must lie "
              "within 8192 m of it)",
              "X,Y,Z")
      .Option("crs", &crs, "the name of those coordinates' CRS, free text (first import)", "NAME")
      .Require({"cloud"})
      .Footer(cli::kExitCodesFooter);
  if (!cli.Parse(args, std::cout)) return cli::kExitOk;
  mds::FrameRequest frame;
  if (cli.Given("origin")) {
    frame.origin = mds::ParseOrigin(origin_text);
    if (!frame.origin)
      cli::FailUsage(cli.program(),
                     "--origin: expected X,Y,Z in metres, got '" + origin_text + "'");
  }
  if (cli.Given("crs")) frame.crs = crs;
  const mds::ServerConfig config = mds::LoadServerConfig(config_path);
  InstallLogSink(mds::LogConfig{"info", "text"});
  mds::MapService service(config, mds::OpenConfiguredStorage(config));
  std::fprintf(stderr, "importing %s ...\n", path.c_str());
  if (!cli.Given("note")) note = std::filesystem::path(path).filename().string();
  std::printf("%s\n", service.ImportPriorFile(path, note, frame).dump(2).c_str());
  return 0;
}

int CheckConfig(const std::vector<std::string>& args) {
  std::string config_path;
  cli::Parser cli("mapdelta-server check-config",
                  "Validates the config (all problems at once) and prints the effective config.");
  AddConfigOption(cli, &config_path).Footer(cli::kExitCodesFooter);
  if (!cli.Parse(args, std::cout)) return cli::kExitOk;
  std::printf("%s\n", mds::DumpServerConfig(mds::LoadServerConfig(config_path)).c_str());
  return 0;
}

// "token create ..." -> ("token create", its options); "serve ..." -> ("serve", options).
int Dispatch(const std::string& command, const std::vector<std::string>& args) {
  if (command == "serve") return Serve(args);
  if (command == "token create") return TokenCreate(args);
  if (command == "token revoke") return TokenRevoke(args);
  if (command == "token list") return TokenList(args);
  if (command == "import-prior") return ImportPrior(args);
  if (command == "check-config") return CheckConfig(args);
  if (command == "export-autoware") return mds::ExportAutowareCommand(args);
  cli::FailUsage("mapdelta-server", "unknown command '" + command + "'");
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "--help" || args[0] == "-h") {
    std::fprintf(args.empty() ? stderr : stdout, "%s", kUsage);
    return args.empty() ? cli::kExitUsage : cli::kExitOk;
  }
  // Two-word commands ("token create") are one command to the dispatcher.
  const bool two_words = args[0] == "token" && args.size() > 1 && args[1].rfind("-", 0) != 0;
  const std::string command = two_words ? args[0] + " " + args[1] : args[0];
  const std::vector<std::string> options(args.begin() + (two_words ? 2 : 1), args.end());
  return cli::RunMain("mapdelta-server " + command, [&] {
    try {
      return Dispatch(command, options);
    } catch (const mds::ApiError& e) {
      // The facade's errors carry their own code (e.g. invalid_cloud): a runtime failure.
      throw md::Error(md::ErrorCode::kIo, std::string(mds::Info(e.code()).name) + ": " + e.what());
    }
  });
}
