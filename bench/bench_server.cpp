// bench_server: keyframes ingested per second and session-commit time for a paper-size
// session (500 keyframes at 800x450 by default) on the server, against baselines in the same
// run: ingest through HTTP (real socket, multipart, one client) vs direct MapService calls
// (no HTTP), and the commit time vs the paper's budget (5 min per trajectory) and our target
// (a 700-keyframe session in 10 s, extrapolated linearly).
//
// Scene: a 300 m street of 5 m boxes (one box removed, one added), cameras 8 m high at
// 1 m spacing looking at it, depth rendered analytically (tests/server/box_scene.hpp).
// Commit baseline (--no-baseline skips it): the session-1 structure, i.e. every PNG decoded
// twice (the clouds stored at upload are made stale, so the commit recomputes them) and the
// octree pass as two halves on two threads (chunk = N/2), merged.
// Usage: bench_server --help
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>

#include "auth.hpp"
#include "box_scene.hpp"
#include "changed_scene.hpp"
#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/http_server.hpp"
#include "mapdelta/server/map_service.hpp"

#include <httplib.h>  // last: its <resolv.h> defines macros that break Eigen

namespace md = mapdelta;
namespace mds = mapdelta::server;
using Clock = std::chrono::steady_clock;

namespace {

double Seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

// CPU seconds used by this process so far (all threads): on a shared, loaded machine the
// wall time says little; CPU / threads is what an idle machine would take at best.
double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double LoadAverage() {
  double load[1] = {0};
  return getloadavg(load, 1) == 1 ? load[0] : -1;
}

mds::Json Meta(int64_t t_ns, const md::SE3& T) {
  const Eigen::Quaterniond q(T.rotation());
  const Eigen::Vector3d t = T.translation();
  return mds::Json{
      {"t_ns", t_ns},
      {"T_map_cam", {{"t", {t.x(), t.y(), t.z()}}, {"q", {q.w(), q.x(), q.y(), q.z()}}}}};
}

struct BenchOptions {
  int keyframes = 500;
  int threads = 2;
  int chunk = mds::PipelineConfig().chunk_keyframes;
  std::string dir = (std::filesystem::temp_directory_path() / "mapdelta_bench_server").string();
  bool no_http = false, no_baseline = false;
};

// nullopt: run with `o`; otherwise the exit code (after --help or a usage error).
std::optional<int> ParseOptions(int argc, char** argv, BenchOptions* o) {
  md::cli::Parser cli(
      "bench_server",
      "Server ingest and commit benchmark: N keyframes at 800x450, ingest over HTTP and\n"
      "through the facade, commit beside the baseline structure (decode twice, two\n"
      "octrees; bench/README.md).");
  cli.Option("keyframes", &o->keyframes, "keyframes in the session")
      .Option("dir", &o->dir, "scratch folder (emptied first)", "DIR")
      .Option("threads", &o->threads, "job threads (pipeline.threads)")
      .Option("chunk", &o->chunk, "pipeline.chunk_keyframes", "K")
      .Flag("no-http", &o->no_http, "skip the HTTP ingest run")
      .Flag("no-baseline", &o->no_baseline, "skip the decode-twice, two-octree commit run")
      .Footer(md::cli::kExitCodesFooter);
  return md::cli::ParseMain(cli, argc, argv, [&] {
    if (o->keyframes < 1 || o->threads < 1 || o->chunk < 1) {
      md::cli::FailUsage(cli.program(),
                         "--keyframes, --threads and --chunk: expected positive integers");
    }
  });
}

}  // namespace

int main(int argc, char** argv) {
  BenchOptions options;
  if (const auto exit_code = ParseOptions(argc, argv, &options)) return *exit_code;
  const int keyframes = options.keyframes, threads = options.threads, chunk = options.chunk;
  const std::string& dir = options.dir;
  const bool http_ingest = !options.no_http, baseline = !options.no_baseline;
  md::log::SetLevel(md::log::Level::kWarn);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);

  // 1. Render and encode the session (not timed as ingest).
  md::PinholeCamera camera;  // 800x450, fx = fy = 400 (the paper's camera)
  const md::testing::BoxScene changed = md::testing::StreetScene(true);
  std::vector<std::string> pngs(keyframes);
  std::vector<md::SE3> poses(keyframes);
  std::fprintf(stderr, "rendering %d keyframes of %dx%d ...\n", keyframes, camera.width,
               camera.height);
  const auto r0 = Clock::now();
  {
    std::vector<std::thread> pool;
    for (int w = 0; w < 2; ++w) {
      pool.emplace_back([&, w] {
        for (int k = w; k < keyframes; k += 2) {
          poses[k] = md::testing::CameraLookingMinusY(-10 + 300.0 * k / keyframes, 30, 8.0, 0.35);
          const auto png = md::EncodeDepthPng(changed.Render(camera, poses[k], 50.0));
          pngs[k].assign(png.begin(), png.end());
        }
      });
    }
    for (auto& t : pool) t.join();
  }
  size_t png_bytes = 0;
  for (const auto& p : pngs) png_bytes += p.size();
  std::fprintf(stderr, "rendered in %.1f s, %.1f MB of PNG\n", Seconds(r0, Clock::now()),
               png_bytes / 1e6);

  // 2. Two databases with the same prior: one ingested through HTTP, one through the facade.
  mds::ServerConfig config;
  config.storage.tile_size_m = 50;
  config.http.port = 0;
  config.pipeline.threads = threads;
  config.pipeline.chunk_keyframes = chunk;
  auto make_service = [&](const std::string& name, const mds::ServerConfig& cfg) {
    mds::ServerConfig c = cfg;
    c.storage.database = dir + "/" + name + ".db";
    auto s = std::make_unique<mds::MapService>(c, mds::OpenSqliteStorage(c.storage.database));
    const std::string prior = dir + "/prior.pcd";
    if (!std::filesystem::exists(prior))
      md::WriteCloud(prior, md::testing::StreetScene(false).Sample(0.4));
    s->ImportPriorFile(prior, "bench");
    return s;
  };
  const mds::Json camera_json{{"width", camera.width}, {"height", camera.height},
                              {"fx", camera.fx},       {"fy", camera.fy},
                              {"cx", camera.cx},       {"cy", camera.cy}};

  double http_s = 0;
  if (http_ingest) {
    auto http_service = make_service("http", config);
    const std::string token = "Bearer " + mds::CreateToken(http_service->storage(), "bench",
                                                           mds::Role::kVehicle, mds::NowMs())
                                              .secret;
    mds::HttpServer http(*http_service);
    const int port = http.Bind("127.0.0.1", 0);
    std::thread server([&] { http.Run(); });
    httplib::Client client("127.0.0.1", port);
    client.set_read_timeout(120, 0);
    const httplib::Headers headers{{"Authorization", token}};
    auto created = client.Post("/v1/sessions", headers,
                               mds::Json{{"vehicle_id", "bench"}, {"camera", camera_json}}.dump(),
                               "application/json");
    if (!created || created->status != 201) {
      std::fprintf(stderr, "session creation failed\n");
      return 1;
    }
    const int64_t http_session = mds::Json::parse(created->body)["session_id"];
    const auto h0 = Clock::now();
    for (int k = 0; k < keyframes; ++k) {
      httplib::MultipartFormDataItems items = {
          {"meta", Meta(1000000000LL * (k + 1), poses[k]).dump(), "", "application/json"},
          {"depth", pngs[k], "d.png", "image/png"}};
      auto r = client.Put(
          "/v1/sessions/" + std::to_string(http_session) + "/keyframes/" + std::to_string(k),
          headers, items);
      if (!r || r->status != 201) {
        std::fprintf(stderr, "upload %d failed: %s\n", k, r ? r->body.c_str() : "no response");
        return 1;
      }
      if ((k + 1) % 100 == 0) std::fprintf(stderr, "  http ingest %d/%d\n", k + 1, keyframes);
    }
    http_s = Seconds(h0, Clock::now());
    http.Stop();
    server.join();
  }

  auto direct_service = make_service("direct", config);
  const int64_t direct_session = direct_service->CreateSession(
      {{"vehicle_id", "bench"}, {"camera", camera_json}})["session_id"];
  const auto d0 = Clock::now();
  for (int k = 0; k < keyframes; ++k) {
    bool stored = false;
    direct_service->PutKeyframe(direct_session, k, Meta(1000000000LL * (k + 1), poses[k]),
                                mds::Bytes(pngs[k].begin(), pngs[k].end()), &stored);
  }
  const double direct_s = Seconds(d0, Clock::now());

  // 3. Commit (in this thread, the job worker's code path) and read back the result.
  struct Commit {
    double wall_s = 0, cpu_s = 0;
    mds::Json result;
  };
  auto commit = [&](mds::MapService& service, int64_t session) {
    service.CommitSession(session);
    Commit c;
    const auto c0 = Clock::now();
    const double cpu0 = CpuSeconds();
    service.RunQueuedJobsNow();
    c.wall_s = Seconds(c0, Clock::now());
    c.cpu_s = CpuSeconds() - cpu0;
    const mds::Json job = service.ListJobs(1, 1)["jobs"][0];
    if (job["state"] != "succeeded") {
      std::fprintf(stderr, "commit failed: %s\n", job.dump().c_str());
      std::exit(1);
    }
    c.result = job["result"];
    return c;
  };
  const Commit fast = commit(*direct_service, direct_session);
  const double commit_s = fast.wall_s, commit_cpu_s = fast.cpu_s;
  const mds::Json& result = fast.result;
  Commit base;
  if (baseline) {
    std::fprintf(stderr, "baseline: ingest with stale clouds, commit in two halves ...\n");
    mds::ServerConfig upload = config;
    upload.pipeline.session_voxel_m = config.pipeline.session_voxel_m * 0.5;  // stale clouds
    int64_t base_session = 0;
    {
      auto uploader = make_service("baseline", upload);
      base_session =
          uploader->CreateSession({{"vehicle_id", "bench"}, {"camera", camera_json}})["session_id"];
      for (int k = 0; k < keyframes; ++k) {
        bool stored = false;
        uploader->PutKeyframe(base_session, k, Meta(1000000000LL * (k + 1), poses[k]),
                              mds::Bytes(pngs[k].begin(), pngs[k].end()), &stored);
      }
    }
    mds::ServerConfig halves = config;
    halves.storage.database = dir + "/baseline.db";
    halves.pipeline.chunk_keyframes = (keyframes + 1) / 2;
    mds::MapService service(halves, mds::OpenSqliteStorage(halves.storage.database));
    base = commit(service, base_session);
    if (base.result["new_points"] != result["new_points"] ||
        base.result["removed_points"] != result["removed_points"]) {
      std::fprintf(stderr, "baseline and fast commit disagree: %s vs %s\n",
                   base.result.dump().c_str(), result.dump().c_str());
      return 1;
    }
  }

  std::printf(
      "bench_server: %d keyframes %dx%d, %.1f MB PNG, %d job threads, chunk %d, load average "
      "%.1f\n",
      keyframes, camera.width, camera.height, png_bytes / 1e6, threads, chunk, LoadAverage());
  std::printf("| measure | mapdelta | baseline | ratio |\n|---|---|---|---|\n");
  if (http_ingest) {
    std::printf(
        "| ingest, keyframes/s | %.1f (HTTP, 1 client) | %.1f (MapService, no HTTP) | %.2f |\n",
        keyframes / http_s, keyframes / direct_s, direct_s / http_s);
  } else {
    std::printf("| ingest, keyframes/s | - (--no-http) | %.1f (MapService, no HTTP) | - |\n",
                keyframes / direct_s);
  }
  if (baseline) {
    std::printf("| commit wall, s | %.2f | %.2f (decode twice, two octrees) | %.2fx faster |\n",
                commit_s, base.wall_s, base.wall_s / commit_s);
    std::printf("| commit CPU, s | %.2f | %.2f (decode twice, two octrees) | %.2fx less |\n",
                commit_cpu_s, base.cpu_s, base.cpu_s / commit_cpu_s);
  }
  std::printf("| commit, s | %.2f | 300 (paper: up to 5 min per trajectory) | %.0fx faster |\n",
              commit_s, 300.0 / commit_s);
  std::printf("| commit of 700 keyframes (linear), s | %.2f | 10 (target) | %s |\n",
              commit_s * 700.0 / keyframes, commit_s * 700.0 / keyframes < 10 ? "meets" : "misses");
  std::printf(
      "commit CPU time %.2f s (both job threads; an idle 2-core machine needs >= %.2f s wall)\n",
      commit_cpu_s, commit_cpu_s / 2);
  std::printf("commit stages [s]: %s\n", result["seconds"].dump().c_str());
  if (baseline) std::printf("baseline stages [s]: %s\n", base.result["seconds"].dump().c_str());
  std::printf("session points %s, tiles aggregated %s, new %s, removed %s, registration %s\n",
              result["session_points"].dump().c_str(), result["tiles_aggregated"].dump().c_str(),
              result["new_points"].dump().c_str(), result["removed_points"].dump().c_str(),
              result["registration"]["status"].dump().c_str());
  std::filesystem::remove_all(dir);
  return 0;
}
