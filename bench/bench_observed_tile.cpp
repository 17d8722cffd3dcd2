// bench_observed_tile: GET /v1/observed/tiles/{t}.bt through MapService with the served-octree
// cache (http.observed_cache_bytes, default 64 MiB) beside the same service with it off (every
// request merges the tile's session octrees and crops the merge, as before the cache), on one
// database: N committed sessions of the server tests' box scene (160x90 analytic depth, 20 m
// tiles, the load run's scene and camera). Per tile: the uncached time per request, the cached
// first request (a miss: the merge), the cached repeats (hits), and the ratio. Every answer of
// both services must be byte-identical (exit 1 otherwise). Without HTTP: the merge is the cost
// the cache removes; the socket and the body copy are the same on both sides.
// Usage: bench_observed_tile --help
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "box_scene.hpp"
#include "changed_scene.hpp"
#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/map_service.hpp"

namespace md = mapdelta;
namespace mds = mapdelta::server;
using Clock = std::chrono::steady_clock;

namespace {

double Ms(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

double LoadAverage() {
  double load[1] = {0};
  return getloadavg(load, 1) == 1 ? load[0] : -1;
}

struct Options {
  int sessions = 30;
  int keyframes = 21;  // per session: x from -5 to 45 m every 2.5 m
  int requests = 10;   // per tile and side
  std::string dir =
      (std::filesystem::temp_directory_path() / "mapdelta_bench_observed_tile").string();
};

std::optional<int> ParseOptions(int argc, char** argv, Options* o) {
  md::cli::Parser cli("bench_observed_tile",
                      "Observed-octree download (GET /v1/observed/tiles/{t}.bt) through the\n"
                      "service, with the served-octree cache beside without it, after N\n"
                      "committed sessions of the box scene (bench/README.md).");
  cli.Option("sessions", &o->sessions, "committed sessions (drives) over the tiles")
      .Option("keyframes", &o->keyframes, "keyframes per session (2.5 m apart)")
      .Option("requests", &o->requests, "requests per tile on each side")
      .Option("dir", &o->dir, "scratch folder (emptied first)", "DIR")
      .Footer(md::cli::kExitCodesFooter);
  return md::cli::ParseMain(cli, argc, argv, [&] {
    if (o->sessions < 1 || o->keyframes < 1 || o->requests < 2) {
      md::cli::FailUsage(cli.program(),
                         "--sessions and --keyframes: positive; --requests: at least 2");
    }
  });
}

mds::ServerConfig Config(const std::string& db, int64_t cache_bytes) {
  mds::ServerConfig c;
  c.storage.database = db;
  c.storage.tile_size_m = 20;
  c.pipeline.max_depth_m = md::testing::kMaxDepth;
  c.http.observed_cache_bytes = cache_bytes;
  return c;
}

// Step 1: the prior and N drives, each a little farther from the boxes (so their octrees differ).
void CommitSessions(mds::MapService& service, const Options& o) {
  using namespace md::testing;  // NOLINT: the shared test scene
  const std::string prior = o.dir + "/prior.pcd";
  md::WriteCloud(prior, PriorScene().Sample(0.4));
  service.ImportPriorFile(prior, "bench");
  const md::PinholeCamera camera = TestCamera();
  const mds::Json camera_json{{"width", camera.width}, {"height", camera.height},
                              {"fx", camera.fx},       {"fy", camera.fy},
                              {"cx", camera.cx},       {"cy", camera.cy}};
  const BoxScene scene = ChangedScene();
  const auto t0 = Clock::now();
  for (int s = 0; s < o.sessions; ++s) {
    const int64_t id = service.CreateSession(
        {{"vehicle_id", "car-" + std::to_string(s % 4)}, {"camera", camera_json}})["session_id"];
    const double y = 22.0 + 0.2 * (s % 20);
    for (int k = 0; k < o.keyframes; ++k) {
      const md::SE3 T = CameraLookingMinusY(-5 + 2.5 * k, y, kCameraHeight, kPitch);
      const auto png = md::EncodeDepthPng(scene.Render(camera, T, kMaxDepth));
      bool stored = false;
      service.PutKeyframe(id, k, MetaJson(1000000000LL * (k + 1), T),
                          mds::Bytes(png.begin(), png.end()), &stored);
    }
    const int64_t job = service.CommitSession(id)["job_id"];
    service.RunQueuedJobsNow();
    if (service.GetJob(job)["state"] != "succeeded") {
      std::fprintf(stderr, "commit of session %lld failed\n", static_cast<long long>(id));
      std::exit(1);
    }
  }
  std::fprintf(stderr, "%d sessions committed in %.1f s\n", o.sessions,
               Ms(t0, Clock::now()) / 1000);
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (auto code = ParseOptions(argc, argv, &o)) return *code;
  md::log::SetLevel(md::log::Level::kWarn);
  std::filesystem::remove_all(o.dir);
  std::filesystem::create_directories(o.dir);
  const std::string db = o.dir + "/bench.db";
  const int64_t cache_bytes = mds::HttpConfig().observed_cache_bytes;
  auto writer = std::make_unique<mds::MapService>(Config(db, 0), mds::OpenSqliteStorage(db));
  CommitSessions(*writer, o);
  writer.reset();
  // Both sides read the same database file.
  mds::MapService uncached(Config(db, 0), mds::OpenSqliteStorage(db));
  mds::MapService cached(Config(db, cache_bytes), mds::OpenSqliteStorage(db));

  std::printf(
      "observed-octree downloads, %d sessions x %d keyframes (160x90), 20 m tiles, "
      "%d requests per tile and side, load average %.1f\n",
      o.sessions, o.keyframes, o.requests, LoadAverage());
  std::printf(
      "| tile | .bt KiB | uncached ms/request | cached 1st (miss) ms | cached hit ms | "
      "ratio uncached / hit |\n|---|---|---|---|---|---|\n");
  double sum_uncached = 0, sum_hit = 0, sum_miss = 0;
  bool identical = true;
  const auto tiles = cached.storage().tiles().ListAggregated(std::nullopt);
  for (const md::TileId& tile : tiles) {
    const std::string t = tile.ToString();
    std::vector<double> plain, hits;
    std::string reference;
    for (int i = 0; i < o.requests; ++i) {
      const auto a = Clock::now();
      const mds::FilePayload p = uncached.GetObservedTile(t);
      plain.push_back(Ms(a, Clock::now()));
      const std::string bytes(p.bytes.begin(), p.bytes.end());
      if (i == 0) reference = bytes;
      identical &= bytes == reference;
    }
    double miss = 0;
    for (int i = 0; i < o.requests; ++i) {
      const auto a = Clock::now();
      const mds::FilePayload p = cached.GetObservedTile(t);
      const double ms = Ms(a, Clock::now());
      if (i == 0)
        miss = ms;
      else
        hits.push_back(ms);
      identical &= std::string(p.bytes.begin(), p.bytes.end()) == reference;
    }
    const double u = Median(plain), h = Median(hits);
    sum_uncached += u;
    sum_hit += h;
    sum_miss += miss;
    std::printf("| %s | %.1f | %.2f | %.2f | %.3f | %.0fx |\n", t.c_str(),
                reference.size() / 1024.0, u, miss, h, h > 0 ? u / h : 0);
  }
  const mds::ObservedCacheStats s = cached.ObservedCacheStatistics();
  std::printf("| all %zu tiles (sum of medians) | | %.2f | %.2f | %.3f | %.0fx |\n", tiles.size(),
              sum_uncached, sum_miss, sum_hit, sum_hit > 0 ? sum_uncached / sum_hit : 0);
  std::printf("cache: %lld hits, %lld misses, %lld entries, %.1f KiB held (bound %lld MiB)\n",
              static_cast<long long>(s.hits), static_cast<long long>(s.misses),
              static_cast<long long>(s.entries), s.bytes / 1024.0,
              static_cast<long long>(cache_bytes >> 20));
  std::printf("answers byte-identical: %s\n", identical ? "yes" : "NO");
  std::filesystem::remove_all(o.dir);
  return identical && !tiles.empty() ? 0 : 1;
}
