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
// Coverage: the commit's coverage stage against the whole commit, and the bytes its rows store.
// Usage: bench_server --help
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

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

// The benchmark's session: keyframe poses along the street and their depth PNGs.
struct Session {
  md::PinholeCamera camera;  // 800x450, fx = fy = 400 (the paper's camera)
  std::vector<md::SE3> poses;
  std::vector<std::string> pngs;
  size_t png_bytes = 0;
  mds::Json CameraJson() const {
    return mds::Json{{"width", camera.width}, {"height", camera.height}, {"fx", camera.fx},
                     {"fy", camera.fy},       {"cx", camera.cx},         {"cy", camera.cy}};
  }
};

// Step 1: render and encode the session on two threads (not timed as ingest).
Session RenderSession(int keyframes) {
  Session s;
  const md::testing::BoxScene changed = md::testing::StreetScene(true);
  s.pngs.resize(keyframes);
  s.poses.resize(keyframes);
  std::fprintf(stderr, "rendering %d keyframes of %dx%d ...\n", keyframes, s.camera.width,
               s.camera.height);
  const auto r0 = Clock::now();
  std::vector<std::thread> pool;
  for (int w = 0; w < 2; ++w) {
    pool.emplace_back([&, w] {
      for (int k = w; k < keyframes; k += 2) {
        s.poses[k] = md::testing::CameraLookingMinusY(-10 + 300.0 * k / keyframes, 30, 8.0, 0.35);
        const auto png = md::EncodeDepthPng(changed.Render(s.camera, s.poses[k], 50.0));
        s.pngs[k].assign(png.begin(), png.end());
      }
    });
  }
  for (auto& t : pool) t.join();
  for (const auto& p : s.pngs) s.png_bytes += p.size();
  std::fprintf(stderr, "rendered in %.1f s, %.1f MB of PNG\n", Seconds(r0, Clock::now()),
               s.png_bytes / 1e6);
  return s;
}

// A service on a new SQLite database DIR/NAME.db holding the unchanged street as its prior.
std::unique_ptr<mds::MapService> MakeService(const std::string& dir, const std::string& name,
                                             mds::ServerConfig config) {
  config.storage.database = dir + "/" + name + ".db";
  auto s =
      std::make_unique<mds::MapService>(config, mds::OpenSqliteStorage(config.storage.database));
  const std::string prior = dir + "/prior.pcd";
  if (!std::filesystem::exists(prior))
    md::WriteCloud(prior, md::testing::StreetScene(false).Sample(0.4));
  s->ImportPriorFile(prior, "bench");
  return s;
}

// Step 2a: every keyframe through HTTP (real socket, multipart, one client); seconds taken,
// nullopt (after a message) when a request fails.
std::optional<double> IngestOverHttp(const Session& session, const std::string& dir,
                                     const mds::ServerConfig& config) {
  auto service = MakeService(dir, "http", config);
  const std::string token =
      "Bearer " +
      mds::CreateToken(service->storage(), "bench", mds::Role::kVehicle, mds::NowMs()).secret;
  mds::HttpServer http(*service);
  const int port = http.Bind("127.0.0.1", 0);
  std::thread server([&] { http.Run(); });
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(120, 0);
  const httplib::Headers headers{{"Authorization", token}};
  std::optional<double> seconds;
  auto created =
      client.Post("/v1/sessions", headers,
                  mds::Json{{"vehicle_id", "bench"}, {"camera", session.CameraJson()}}.dump(),
                  "application/json");
  if (!created || created->status != 201) {
    std::fprintf(stderr, "session creation failed\n");
  } else {
    const int64_t id = mds::Json::parse(created->body)["session_id"];
    const auto h0 = Clock::now();
    const int keyframes = static_cast<int>(session.pngs.size());
    bool failed = false;
    for (int k = 0; k < keyframes && !failed; ++k) {
      httplib::MultipartFormDataItems items = {
          {"meta", Meta(1000000000LL * (k + 1), session.poses[k]).dump(), "", "application/json"},
          {"depth", session.pngs[k], "d.png", "image/png"}};
      auto r = client.Put("/v1/sessions/" + std::to_string(id) + "/keyframes/" + std::to_string(k),
                          headers, items);
      if (!r || r->status != 201) {
        std::fprintf(stderr, "upload %d failed: %s\n", k, r ? r->body.c_str() : "no response");
        failed = true;
      }
      if ((k + 1) % 100 == 0) std::fprintf(stderr, "  http ingest %d/%d\n", k + 1, keyframes);
    }
    if (!failed) seconds = Seconds(h0, Clock::now());
  }
  http.Stop();
  server.join();
  return seconds;
}

// Step 2b: every keyframe through the facade (no HTTP) into a new session of `service`.
int64_t IngestDirect(mds::MapService& service, const Session& session) {
  const int64_t id = service.CreateSession(
      {{"vehicle_id", "bench"}, {"camera", session.CameraJson()}})["session_id"];
  for (size_t k = 0; k < session.pngs.size(); ++k) {
    bool stored = false;
    service.PutKeyframe(id, static_cast<int64_t>(k), Meta(1000000000LL * (k + 1), session.poses[k]),
                        mds::Bytes(session.pngs[k].begin(), session.pngs[k].end()), &stored);
  }
  return id;
}

struct Commit {
  double wall_s = 0, cpu_s = 0;
  mds::Json result;
};

// Step 3: commit in this thread (the job worker's code path) and read back the result;
// nullopt (after a message) when the job failed.
std::optional<Commit> RunCommit(mds::MapService& service, int64_t session) {
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
    return std::nullopt;
  }
  c.result = job["result"];
  return c;
}

// Step 4, the baseline: the same session ingested with stale clouds (so the commit decodes
// every PNG again) and committed in two halves (two octrees, merged).
std::optional<Commit> RunBaselineCommit(const Session& session, const std::string& dir,
                                        const mds::ServerConfig& config) {
  std::fprintf(stderr, "baseline: ingest with stale clouds, commit in two halves ...\n");
  mds::ServerConfig upload = config;
  upload.pipeline.session_voxel_m = config.pipeline.session_voxel_m * 0.5;  // stale clouds
  const int64_t id = IngestDirect(*MakeService(dir, "baseline", upload), session);
  mds::ServerConfig halves = config;
  halves.storage.database = dir + "/baseline.db";
  halves.pipeline.chunk_keyframes = (static_cast<int>(session.pngs.size()) + 1) / 2;
  mds::MapService service(halves, mds::OpenSqliteStorage(halves.storage.database));
  return RunCommit(service, id);
}

// What coverage (issue #20 item 4) adds to a commit: the job's coverage stage (which runs alone,
// between aggregation and classification, so the commit without it takes total - coverage),
// and the stored bytes of its rows per prior point they index.
void PrintCoverage(mds::MapService& service, const Commit& fast, int keyframes) {
  const double coverage_s = fast.result["seconds"].value("coverage", 0.0);
  const double total_s = fast.result["seconds"].value("total", 0.0);
  int64_t rows = 0, bytes = 0, points = 0, observed = 0;
  const mds::Rect all{-1e9, -1e9, 1e9, 1e9};
  for (const mds::CoverageRecord& r : service.storage().coverage().List(all, 0, true)) {
    ++rows;
    bytes += static_cast<int64_t>(r.bits.size());
    points += r.prior_points;
    observed += r.observed_points;
  }
  std::printf(
      "coverage: %.3f s of the %.3f s commit (%.1f%%; without it %.3f s, ratio %.3f), %.3f ms per "
      "keyframe; %lld rows, %lld bytes of bitsets over %lld prior points (%.3f bytes / %.2f bits "
      "per prior point per session), %lld observed\n",
      coverage_s, total_s, 100 * coverage_s / total_s, total_s - coverage_s,
      total_s / (total_s - coverage_s), 1000 * coverage_s / keyframes, static_cast<long long>(rows),
      static_cast<long long>(bytes), static_cast<long long>(points),
      points ? static_cast<double>(bytes) / points : 0.0, points ? 8.0 * bytes / points : 0.0,
      static_cast<long long>(observed));
}

void PrintReport(const BenchOptions& o, const Session& session, std::optional<double> http_s,
                 double direct_s, const Commit& fast, const std::optional<Commit>& base) {
  const int keyframes = o.keyframes;
  const mds::Json& result = fast.result;
  std::printf(
      "bench_server: %d keyframes %dx%d, %.1f MB PNG, %d job threads, chunk %d, load average "
      "%.1f\n",
      keyframes, session.camera.width, session.camera.height, session.png_bytes / 1e6, o.threads,
      o.chunk, LoadAverage());
  std::printf("| measure | mapdelta | baseline | ratio |\n|---|---|---|---|\n");
  if (http_s) {
    std::printf(
        "| ingest, keyframes/s | %.1f (HTTP, 1 client) | %.1f (MapService, no HTTP) | %.2f |\n",
        keyframes / *http_s, keyframes / direct_s, direct_s / *http_s);
  } else {
    std::printf("| ingest, keyframes/s | - (--no-http) | %.1f (MapService, no HTTP) | - |\n",
                keyframes / direct_s);
  }
  if (base) {
    std::printf("| commit wall, s | %.2f | %.2f (decode twice, two octrees) | %.2fx faster |\n",
                fast.wall_s, base->wall_s, base->wall_s / fast.wall_s);
    std::printf("| commit CPU, s | %.2f | %.2f (decode twice, two octrees) | %.2fx less |\n",
                fast.cpu_s, base->cpu_s, base->cpu_s / fast.cpu_s);
  }
  std::printf("| commit, s | %.2f | 300 (paper: up to 5 min per trajectory) | %.0fx faster |\n",
              fast.wall_s, 300.0 / fast.wall_s);
  std::printf("| commit of 700 keyframes (linear), s | %.2f | 10 (target) | %s |\n",
              fast.wall_s * 700.0 / keyframes,
              fast.wall_s * 700.0 / keyframes < 10 ? "meets" : "misses");
  std::printf(
      "commit CPU time %.2f s (both job threads; an idle 2-core machine needs >= %.2f s wall)\n",
      fast.cpu_s, fast.cpu_s / 2);
  std::printf("commit stages [s]: %s\n", result["seconds"].dump().c_str());
  if (base) std::printf("baseline stages [s]: %s\n", base->result["seconds"].dump().c_str());
  std::printf("session points %s, tiles aggregated %s, new %s, removed %s, registration %s\n",
              result["session_points"].dump().c_str(), result["tiles_aggregated"].dump().c_str(),
              result["new_points"].dump().c_str(), result["removed_points"].dump().c_str(),
              result["registration"]["status"].dump().c_str());
}

}  // namespace

int main(int argc, char** argv) {
  BenchOptions options;
  if (const auto exit_code = ParseOptions(argc, argv, &options)) return *exit_code;
  md::log::SetLevel(md::log::Level::kWarn);
  const std::string& dir = options.dir;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);

  const Session session = RenderSession(options.keyframes);
  mds::ServerConfig config;
  config.storage.tile_size_m = 50;
  config.http.port = 0;
  config.pipeline.threads = options.threads;
  config.pipeline.chunk_keyframes = options.chunk;

  // Two databases with the same prior: one ingested through HTTP, one through the facade.
  std::optional<double> http_s;
  if (!options.no_http) {
    http_s = IngestOverHttp(session, dir, config);
    if (!http_s) return 1;
  }
  auto direct_service = MakeService(dir, "direct", config);
  const auto d0 = Clock::now();
  const int64_t direct_session = IngestDirect(*direct_service, session);
  const double direct_s = Seconds(d0, Clock::now());

  const std::optional<Commit> fast = RunCommit(*direct_service, direct_session);
  if (!fast) return 1;
  std::optional<Commit> base;
  if (!options.no_baseline) {
    base = RunBaselineCommit(session, dir, config);
    if (!base) return 1;
    if (base->result["new_points"] != fast->result["new_points"] ||
        base->result["removed_points"] != fast->result["removed_points"]) {
      std::fprintf(stderr, "baseline and fast commit disagree: %s vs %s\n",
                   base->result.dump().c_str(), fast->result.dump().c_str());
      return 1;
    }
  }
  PrintReport(options, session, http_s, direct_s, *fast, base);
  PrintCoverage(*direct_service, *fast, options.keyframes);
  std::filesystem::remove_all(dir);
  return 0;
}
