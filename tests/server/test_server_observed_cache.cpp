// The served observed-octree cache (server/src/observed_tile_cache.hpp): the cache alone
// (byte bound, least recently used out, one build for concurrent requests, failed builds not
// kept, 0 = off), then behind MapService on each storage backend: a hit is the bytes of the
// merge, a commit by another service on the same database makes the cached entry stale at once,
// and a client that names the current ETag is told "not modified" without a merge.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <stdexcept>
#include <thread>

#include "box_scene.hpp"
#include "changed_scene.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/map_service.hpp"
#include "observed_tile_cache.hpp"
#include "server_backends.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta::server {
namespace {

using namespace mapdelta::testing;  // NOLINT: the shared test scene
namespace fs = std::filesystem;

// A build that counts its calls and makes `size` bytes of `fill`.
struct CountingBuild {
  std::atomic<int> calls{0};
  std::function<std::string()> Of(size_t size, char fill) {
    return [this, size, fill] {
      ++calls;
      return std::string(size, fill);
    };
  }
};

TEST(ObservedTileCache, ByteBoundEvictsTheLeastRecentlyUsed) {
  // Entries count their bytes and their key's: 3 x (30 + 1) = 93 fit in 100, a fourth does not.
  ObservedTileCache cache(100);
  CountingBuild a, b, c, d;
  EXPECT_EQ(*cache.Get("a", a.Of(30, 'a')), std::string(30, 'a'));
  cache.Get("b", b.Of(30, 'b'));
  cache.Get("c", c.Of(30, 'c'));
  EXPECT_EQ(cache.Stats().bytes, 93);
  cache.Get("a", a.Of(30, 'a'));  // a used again: b is now the least recently used
  cache.Get("d", d.Of(30, 'd'));
  ObservedCacheStats s = cache.Stats();
  EXPECT_EQ(s.evictions, 1);
  EXPECT_EQ(s.entries, 3);
  EXPECT_EQ(s.bytes, 93);
  EXPECT_EQ(s.hits, 1);
  EXPECT_EQ(s.misses, 4);
  for (const auto& [key, build] : {std::pair<const char*, CountingBuild*>{"a", &a},
                                   std::pair<const char*, CountingBuild*>{"c", &c},
                                   std::pair<const char*, CountingBuild*>{"d", &d}}) {
    cache.Get(key, build->Of(30, key[0]));
    EXPECT_EQ(build->calls, 1) << key << " should still be cached";
  }
  EXPECT_EQ(*cache.Get("b", b.Of(30, 'b')), std::string(30, 'b'));
  EXPECT_EQ(b.calls, 2) << "b was evicted, so built again";
  EXPECT_LE(cache.Stats().bytes, 100);
}

TEST(ObservedTileCache, AnEntryLargerThanTheBoundIsServedNotKept) {
  ObservedTileCache cache(100);
  CountingBuild big;
  EXPECT_EQ(cache.Get("big", big.Of(200, 'x'))->size(), 200u);
  EXPECT_EQ(cache.Get("big", big.Of(200, 'x'))->size(), 200u);
  EXPECT_EQ(big.calls, 2);
  EXPECT_EQ(cache.Stats().too_large, 2);
  EXPECT_EQ(cache.Stats().bytes, 0);
}

TEST(ObservedTileCache, ZeroBytesIsOff) {
  ObservedTileCache cache(0);
  CountingBuild a;
  cache.Get("a", a.Of(10, 'a'));
  cache.Get("a", a.Of(10, 'a'));
  EXPECT_EQ(a.calls, 2);
  EXPECT_EQ(cache.Stats().hits, 0);
  EXPECT_EQ(cache.Stats().misses, 2);
  EXPECT_EQ(cache.Stats().entries, 0);
}

TEST(ObservedTileCache, ConcurrentRequestsForOneKeyBuildOnce) {
  ObservedTileCache cache(1 << 20);
  std::atomic<bool> release{false};
  std::atomic<int> calls{0};
  auto slow = [&] {
    ++calls;
    while (!release) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    return std::string("merged");
  };
  std::string first, second;
  std::thread builder([&] { first = *cache.Get("t", slow); });
  while (calls == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  std::thread waiter([&] { second = *cache.Get("t", slow); });
  // The second request is waiting for the first one's build (counted before it waits).
  for (int i = 0; i < 5000 && cache.Stats().shared == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  EXPECT_EQ(cache.Stats().shared, 1);
  release = true;
  builder.join();
  waiter.join();
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(first, "merged");
  EXPECT_EQ(second, "merged");
}

TEST(ObservedTileCache, AFailedBuildIsSeenByItsWaitersAndNotKept) {
  ObservedTileCache cache(1 << 20);
  std::atomic<bool> release{false};
  std::atomic<int> calls{0};
  auto failing = [&]() -> std::string {
    ++calls;
    while (!release) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    throw std::runtime_error("storage gone");
  };
  std::atomic<int> failures{0};
  std::thread builder([&] {
    try {
      cache.Get("t", failing);
    } catch (const std::runtime_error&) {
      ++failures;
    }
  });
  while (calls == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  std::thread waiter([&] {
    try {
      cache.Get("t", failing);
    } catch (const std::runtime_error&) {
      ++failures;
    }
  });
  for (int i = 0; i < 5000 && cache.Stats().shared == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  release = true;
  builder.join();
  waiter.join();
  EXPECT_EQ(failures, 2);
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(cache.Stats().entries, 0);
  EXPECT_EQ(*cache.Get("t", [] { return std::string("ok"); }), "ok");  // built anew
}

// ---------------------------------------------------------------- behind MapService

const Json kCamera{{"width", 160}, {"height", 90}, {"fx", 80}, {"fy", 80}, {"cx", 80}, {"cy", 45}};

// One drive along x at y_cam over the changed scene, committed and run by `service`.
void DriveAndCommit(MapService& service, double y_cam) {
  const int64_t s =
      service.CreateSession({{"vehicle_id", "car"}, {"camera", kCamera}})["session_id"];
  const BoxScene scene = ChangedScene();
  int64_t seq = 0;
  for (double x = -5; x <= 45; x += 2.5, ++seq) {
    const SE3 T = CameraLookingMinusY(x, y_cam, kCameraHeight, kPitch);
    const auto png = EncodeDepthPng(scene.Render(TestCamera(), T, kMaxDepth));
    bool stored = false;
    service.PutKeyframe(s, seq, MetaJson(1000000000LL * (seq + 1), T),
                        Bytes(png.begin(), png.end()), &stored);
  }
  const int64_t job = service.CommitSession(s)["job_id"];
  service.RunQueuedJobsNow();
  ASSERT_EQ(service.GetJob(job)["state"], "succeeded");
}

class ObservedCacheService : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    log::SetLevel(log::Level::kWarn);
    dir_ = FreshTempDir("mds_observed_cache");
    config_.storage.tile_size_m = 20;
    config_.pipeline.max_depth_m = kMaxDepth;
    config_.pipeline.free_space_depth_m = 20;
    config_.classify.th_ch_m = 2.4;
    UseFreshDatabase(GetParam(), dir_, &config_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A service on the test's database; observed_cache_bytes as given.
  std::unique_ptr<MapService> Open(int64_t observed_cache_bytes) {
    ServerConfig c = config_;
    c.http.observed_cache_bytes = observed_cache_bytes;
    return std::make_unique<MapService>(c, OpenConfiguredStorage(c));
  }

  fs::path dir_;
  ServerConfig config_;
};

std::string Text(const FilePayload& p) { return std::string(p.bytes.begin(), p.bytes.end()); }

TEST_P(ObservedCacheService, HitsServeTheMergeAndAnotherServicesCommitMakesThemStale) {
  auto cached = Open(64 << 20);
  auto other = Open(0);  // the uncached reference, and a second writer on the same database
  const std::string prior = (dir_ / "prior.pcd").string();
  WriteCloud(prior, PriorScene().Sample(0.4));
  cached->ImportPriorFile(prior, "test");
  DriveAndCommit(*cached, 25.0);

  // 1. Miss, then hit: the same bytes as the uncached merge, merged once.
  const FilePayload miss = cached->GetObservedTile("0_0");
  const FilePayload hit = cached->GetObservedTile("0_0");
  const FilePayload reference = other->GetObservedTile("0_0");
  ASSERT_EQ(Text(miss).rfind("# Octomap OcTree binary file", 0), 0u);
  EXPECT_EQ(Text(hit), Text(miss));
  EXPECT_EQ(Text(hit), Text(reference));
  EXPECT_EQ(hit.etag, miss.etag);
  EXPECT_EQ(hit.etag, reference.etag) << "two servers on one database name a state alike";
  ObservedCacheStats s = cached->ObservedCacheStatistics();
  EXPECT_EQ(s.misses, 1);
  EXPECT_EQ(s.hits, 1);
  EXPECT_EQ(s.entries, 1);
  EXPECT_GE(s.bytes, static_cast<int64_t>(miss.bytes.size()));
  EXPECT_NE(
      cached->RenderMetrics().find("mapdelta_observed_cache_requests_total{result=\"hit\"} 1\n"),
      std::string::npos);

  // 2. If-None-Match with the current ETag: no bytes and no merge (the adapter answers 304);
  // another ETag gets the bytes.
  int asked = 0;
  const FilePayload not_modified = cached->GetObservedTile("0_0", [&](const std::string& e) {
    ++asked;
    return e == miss.etag;
  });
  EXPECT_EQ(asked, 1);
  EXPECT_TRUE(not_modified.bytes.empty());
  EXPECT_EQ(not_modified.etag, miss.etag);
  EXPECT_EQ(Text(cached->GetObservedTile("0_0", [](const std::string&) { return false; })),
            Text(miss));
  s = cached->ObservedCacheStatistics();
  EXPECT_EQ(s.misses + s.hits, 3) << "the 304 answer must not have looked at the cache";

  // 3. A second session committed through the other service (as another server process
  // would): the cached entry is stale, the next answer is the new merge.
  DriveAndCommit(*other, 24.0);
  const FilePayload after = cached->GetObservedTile("0_0");
  const FilePayload after_reference = other->GetObservedTile("0_0");
  EXPECT_NE(after.etag, miss.etag);
  EXPECT_NE(Text(after), Text(miss)) << "the second drive observed more of the tile";
  EXPECT_EQ(Text(after), Text(after_reference));
  EXPECT_EQ(after.etag, after_reference.etag);
  EXPECT_EQ(cached->ObservedCacheStatistics().misses, 2);
  // The old ETag no longer matches: a client holding it gets the new bytes.
  EXPECT_EQ(
      Text(cached->GetObservedTile("0_0", [&](const std::string& e) { return e == miss.etag; })),
      Text(after));
  EXPECT_THROW(cached->GetObservedTile("40_40"), ApiError);  // never observed: 404
}

INSTANTIATE_TEST_SUITE_P(Backends, ObservedCacheService, ::testing::ValuesIn(kServerBackends),
                         BackendName());

}  // namespace
}  // namespace mapdelta::server
