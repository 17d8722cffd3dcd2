// bench_scale_out: ingest keyframes/s and commit latency of 1, 2 and 4 mapdelta-server
// processes on one PostgreSQL, beside the baseline of one process on SQLite, in one run on
// this machine. Each configuration gets a fresh database and the same load: U vehicles
// (threads, default 16) each upload K keyframes (800x450 16-bit depth PNGs of a box street,
// rendered once) over HTTP on loopback, vehicle i to process i % N; then every vehicle
// commits at once and the commit latency is the time until the last job succeeded. Every
// process serves the API and runs a job worker. PostgreSQL runs durably (fsync on), like
// SQLite's synchronous=FULL: a 201 is on disk in both.
// During ingest it also accounts CPU seconds (from /proc) of the server processes, of
// PostgreSQL (postmaster and backends) and of the uploaders (this process), per keyframe and as
// cores kept busy, so that a CPU-bound machine shows as such.
// Usage: bench_scale_out [--uploaders U] [--keyframes K] [--processes 1,2,4] [--width W]
//                        [--height H] [--dir DIR]
#include <signal.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_scale_out_cpu.hpp"
#include "box_scene.hpp"
#include "changed_scene.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "server_process.hpp"
#include "temp_postgres.hpp"

#include <httplib.h>  // last: its <resolv.h> defines macros that break Eigen

namespace md = mapdelta;
namespace fs = std::filesystem;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

struct Options {
  int uploaders = 16, keyframes = 30, width = 800, height = 450;
  std::vector<int> processes = {1, 2, 4};
  fs::path dir = fs::temp_directory_path() / "mapdelta_bench_scale_out";
};

struct Keyframe {
  std::string meta, png;
};

struct Result {
  std::string name;
  double ingest_kf_s = 0, commit_s = 0;
  int errors = 0, keyframes = 0;
  std::map<int, int> upload_errors;  // HTTP status (0 = no answer) -> count
  // CPU seconds during ingest, and its wall time.
  double server_cpu_s = 0, postgres_cpu_s = 0, uploader_cpu_s = 0, ingest_s = 0;
};

// CPU seconds so far of the server processes, of PostgreSQL (postgres_pid < 0: none) and of
// the uploaders.
struct CpuSample {
  double server = 0, postgres = 0, uploaders = 0;
};
CpuSample SampleCpu(const std::vector<pid_t>& servers, pid_t postgres_pid) {
  CpuSample c;
  for (pid_t p : servers) c.server += md::bench::ReadProcStat(p).cpu_s;
  if (postgres_pid > 0) c.postgres = md::bench::CpuWithChildren(postgres_pid);
  c.uploaders = md::bench::OwnCpu();
  return c;
}

md::PinholeCamera Camera(const Options& o) {
  md::PinholeCamera c;
  c.width = o.width;
  c.height = o.height;
  c.fx = c.fy = o.width / 2.0;
  c.cx = o.width / 2.0;
  c.cy = o.height / 2.0;
  return c;
}

// One drive along the street (1 m steps, 8 m high, looking at the boxes), shared by all.
std::vector<Keyframe> Drive(const Options& o) {
  const md::testing::BoxScene scene = md::testing::StreetScene(true);
  std::vector<Keyframe> out;
  for (int i = 0; i < o.keyframes; ++i) {
    const md::SE3 T = md::testing::CameraLookingMinusY(i * 1.0, 40.0, 8.0, 0.35);
    const auto png = md::EncodeDepthPng(scene.Render(Camera(o), T, 50.0));
    const Eigen::Quaterniond q(T.rotation());
    const Eigen::Vector3d t = T.translation();
    const Json meta{
        {"t_ns", 1000000000LL * (i + 1)},
        {"T_map_cam", {{"t", {t.x(), t.y(), t.z()}}, {"q", {q.w(), q.x(), q.y(), q.z()}}}}};
    out.push_back({meta.dump(), std::string(png.begin(), png.end())});
  }
  return out;
}

std::string Token(const std::string& config, const std::string& role) {
  int code = 0;
  const std::string out = md::testing::RunCli(
      "token create --config " + config + " --role " + role + " --name bench-" + role, &code);
  const auto at = out.find("token: ");
  if (code != 0 || at == std::string::npos) throw std::runtime_error("token create failed: " + out);
  return "Bearer " + out.substr(at + 7, out.find('\n', at) - at - 7);
}

// Waits for a job; returns true if it succeeded.
bool WaitJob(httplib::Client& c, const std::string& admin, int64_t job) {
  for (int i = 0; i < 12000; ++i) {
    auto r = c.Get("/v1/admin/jobs/" + std::to_string(job), {{"Authorization", admin}});
    if (r && r->status == 200) {
      const std::string state = Json::parse(r->body).value("state", "");
      if (state == "succeeded") return true;
      if (state == "failed" || state == "cancelled") return false;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

// The U vehicles upload their K keyframes, vehicle i to port i % N: keyframes/s and errors.
void Ingest(const Options& o, const std::vector<Keyframe>& drive, const std::vector<int>& ports,
            const std::vector<pid_t>& server_pids, pid_t postgres_pid, const std::string& vehicle,
            std::vector<int64_t>* sessions, Result* result) {
  const md::PinholeCamera k = Camera(o);
  const Json camera{{"width", k.width}, {"height", k.height}, {"fx", k.fx},
                    {"fy", k.fy},       {"cx", k.cx},         {"cy", k.cy}};
  for (int i = 0; i < o.uploaders; ++i) {
    httplib::Client c("127.0.0.1", ports[i % ports.size()]);
    auto r = c.Post("/v1/sessions", {{"Authorization", vehicle}},
                    Json{{"vehicle_id", "car-" + std::to_string(i)}, {"camera", camera}}.dump(),
                    "application/json");
    if (!r || r->status != 201) throw std::runtime_error("session create failed");
    sessions->push_back(Json::parse(r->body)["session_id"].get<int64_t>());
  }
  std::mutex errors_mutex;
  const CpuSample cpu0 = SampleCpu(server_pids, postgres_pid);
  const auto t0 = Clock::now();
  std::vector<std::thread> threads;
  for (int i = 0; i < o.uploaders; ++i) {
    threads.emplace_back([&, i] {
      httplib::Client c("127.0.0.1", ports[i % ports.size()]);
      c.set_read_timeout(120, 0);
      for (int seq = 0; seq < o.keyframes; ++seq) {
        const httplib::MultipartFormDataItems items = {
            {"meta", drive[seq].meta, "", "application/json"},
            {"depth", drive[seq].png, "d.png", "image/png"}};
        auto r = c.Put(
            "/v1/sessions/" + std::to_string((*sessions)[i]) + "/keyframes/" + std::to_string(seq),
            {{"Authorization", vehicle}}, items);
        if (!r || r->status != 201) {
          std::lock_guard lock(errors_mutex);
          ++result->upload_errors[r ? r->status : 0];
        }
      }
    });
  }
  for (auto& t : threads) t.join();
  const double s = std::chrono::duration<double>(Clock::now() - t0).count();
  const CpuSample cpu1 = SampleCpu(server_pids, postgres_pid);
  result->server_cpu_s = cpu1.server - cpu0.server;
  result->postgres_cpu_s = cpu1.postgres - cpu0.postgres;
  result->uploader_cpu_s = cpu1.uploaders - cpu0.uploaders;
  result->ingest_s = s;
  result->keyframes = o.uploaders * o.keyframes;
  result->ingest_kf_s = result->keyframes / s;
  for (const auto& [status, n] : result->upload_errors) result->errors += n;
}

// Commits every session at once; seconds until the last job succeeded.
void CommitAll(const std::vector<int>& ports, const std::string& vehicle, const std::string& admin,
               const std::vector<int64_t>& sessions, Result* result) {
  const auto t0 = Clock::now();
  std::vector<int64_t> jobs;
  for (size_t i = 0; i < sessions.size(); ++i) {
    httplib::Client c("127.0.0.1", ports[i % ports.size()]);
    auto r = c.Post("/v1/sessions/" + std::to_string(sessions[i]) + "/commit",
                    httplib::Headers{{"Authorization", vehicle}});
    if (!r || r->status != 202) {
      ++result->errors;
      continue;
    }
    jobs.push_back(Json::parse(r->body)["job_id"].get<int64_t>());
  }
  httplib::Client c("127.0.0.1", ports[0]);
  for (int64_t job : jobs) result->errors += WaitJob(c, admin, job) ? 0 : 1;
  result->commit_s = std::chrono::duration<double>(Clock::now() - t0).count();
}

Result RunOne(const Options& o, const std::vector<Keyframe>& drive, const std::string& name,
              const std::string& storage_yaml, int processes, pid_t postgres_pid,
              const fs::path& dir) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string config = (dir / "server.yaml").string();
  std::ofstream(config) << "storage:\n"
                        << storage_yaml << "  tile_size_m: 50\n"
                        << "http:\n  max_keyframe_bytes: 16777216\nlog:\n  level: warn\n";
  const std::string admin = Token(config, "admin"), vehicle = Token(config, "vehicle");
  std::vector<std::unique_ptr<md::testing::ServerProcess>> servers;
  std::vector<int> ports;
  std::vector<pid_t> pids;
  for (int i = 0; i < processes; ++i) {
    servers.push_back(
        std::make_unique<md::testing::ServerProcess>(config, (dir / "server.log").string()));
    ports.push_back(servers.back()->port());
    pids.push_back(servers.back()->pid());
  }
  {  // the prior: the street before the change
    const std::string pcd = (dir / "prior.pcd").string();
    md::WriteCloud(pcd, md::testing::StreetScene(false).Sample(0.4));
    std::ifstream in(pcd, std::ios::binary);
    httplib::Client c("127.0.0.1", ports[0]);
    c.set_read_timeout(120, 0);
    auto r =
        c.Post("/v1/admin/prior?format=pcd", {{"Authorization", admin}},
               std::string((std::istreambuf_iterator<char>(in)), {}), "application/octet-stream");
    if (!r || r->status != 201) throw std::runtime_error("prior import failed");
  }
  Result result;
  result.name = name;
  std::vector<int64_t> sessions;
  Ingest(o, drive, ports, pids, postgres_pid, vehicle, &sessions, &result);
  CommitAll(ports, vehicle, admin, sessions, &result);
  for (auto& s : servers) s->Kill(SIGTERM);
  return result;
}

Options ParseOptions(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--help" || !has_value) {
      std::printf(
          "usage: bench_scale_out [--uploaders U] [--keyframes K] [--processes 1,2,4] "
          "[--width W] [--height H] [--dir DIR]\n");
      std::exit(a == "--help" ? 0 : 2);
    }
    const std::string v = argv[++i];
    if (a == "--uploaders")
      o.uploaders = std::stoi(v);
    else if (a == "--keyframes")
      o.keyframes = std::stoi(v);
    else if (a == "--width")
      o.width = std::stoi(v);
    else if (a == "--height")
      o.height = std::stoi(v);
    else if (a == "--dir")
      o.dir = v;
    else if (a == "--processes") {
      o.processes.clear();
      std::stringstream ss(v);
      for (std::string n; std::getline(ss, n, ',');) o.processes.push_back(std::stoi(n));
    } else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      std::exit(2);
    }
  }
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = ParseOptions(argc, argv);
  try {
    std::printf("rendering %d keyframes of %dx%d ...\n", o.keyframes, o.width, o.height);
    const std::vector<Keyframe> drive = Drive(o);
    md::testing::TempPostgres postgres(/*durable=*/true);
    std::vector<Result> results;
    results.push_back(
        RunOne(o, drive, "sqlite, 1 process",
               "  backend: sqlite\n  database: " + (o.dir / "sqlite" / "db.sqlite").string() + "\n",
               1, -1, o.dir / "sqlite"));
    for (int n : o.processes) {
      const std::string db = "bench_" + std::to_string(n);
      const std::string url = postgres.CreateDatabase(db);
      results.push_back(RunOne(o, drive, "postgres, " + std::to_string(n) + " process(es)",
                               "  backend: postgres\n  postgres_url: \"" + url + "\"\n", n,
                               postgres.pid(), o.dir / db));
    }
    std::printf("\n%d uploaders x %d keyframes (%dx%d), loopback, load average at end %.1f\n",
                o.uploaders, o.keyframes, o.width, o.height, [] {
                  double l[1] = {0};
                  return getloadavg(l, 1) == 1 ? l[0] : -1;
                }());
    std::printf("%-26s %12s %10s %12s %10s %7s\n", "configuration", "ingest kf/s", "vs sqlite",
                "commit all s", "vs sqlite", "errors");
    int errors = 0;
    for (const Result& r : results) {
      std::printf("%-26s %12.1f %9.2fx %12.2f %9.2fx %7d\n", r.name.c_str(), r.ingest_kf_s,
                  r.ingest_kf_s / results[0].ingest_kf_s, r.commit_s,
                  results[0].commit_s / r.commit_s, r.errors);
      errors += r.errors;
    }
    std::printf("\ningest CPU (ms per keyframe) and cores kept busy (CPU s / wall s), %ld cores\n",
                sysconf(_SC_NPROCESSORS_ONLN));
    std::printf("%-26s %8s %9s %10s %14s %12s  %s\n", "configuration", "server", "postgres",
                "uploaders", "server cores", "all cores", "upload errors by status");
    for (const Result& r : results) {
      const double kf = r.keyframes > 0 ? r.keyframes : 1;
      std::string by_status;
      for (const auto& [status, n] : r.upload_errors)
        by_status += std::to_string(status) + ":" + std::to_string(n) + " ";
      std::printf("%-26s %8.2f %9.2f %10.2f %14.2f %12.2f  %s\n", r.name.c_str(),
                  1e3 * r.server_cpu_s / kf, 1e3 * r.postgres_cpu_s / kf,
                  1e3 * r.uploader_cpu_s / kf, r.server_cpu_s / r.ingest_s,
                  (r.server_cpu_s + r.postgres_cpu_s + r.uploader_cpu_s) / r.ingest_s,
                  by_status.empty() ? "none" : by_status.c_str());
    }
    fs::remove_all(o.dir);
    return errors == 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_scale_out: %s\n", e.what());
    return 1;
  }
}
