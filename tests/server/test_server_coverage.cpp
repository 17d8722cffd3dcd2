// Coverage and freshness (issue #20 item 4) through the facade on the in-memory storage, SQLite
// and PostgreSQL: real commits of drives over a flat ground (analytic depth). The prior of tile
// 0_0 is two equal patches of ground, one in front of the drive at y = 16 (seen) and one
// behind it (never in view), so one session observes exactly half of the tile. The oracle for
// every count is the sessions' stored octrees asked point by point (ObservedArea::IsObserved).
// Then: a window of days leaves an old session out, a refresh that changes the prior and a
// rollback or an import recompute the coverage against the new points, and bad parameters are
// refused (also over HTTP, as 400).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "blob_codec.hpp"
#include "changed_scene.hpp"
#include "coverage.hpp"
#include "http_test_server.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/observed_area.hpp"
#include "mapdelta/server/map_service.hpp"
#include "mapdelta/server/memory_storage.hpp"
#include "server_backends.hpp"

namespace mapdelta::server {
namespace {

namespace fs = std::filesystem;
using namespace mapdelta::testing;  // NOLINT: the shared test scene

constexpr int64_t kDayMs = 86'400'000;
const Json kCamera{{"width", 160}, {"height", 90}, {"fx", 80}, {"fy", 80}, {"cx", 80}, {"cy", 45}};

// A 4 x 4 m patch of ground points, 0.5 m apart, from (x0, y0).
PointCloud GroundPatch(float x0, float y0) {
  PointCloud out;
  for (int i = 0; i < 8; ++i) {
    for (int j = 0; j < 8; ++j)
      out.emplace_back(x0 + 0.5f * i + 0.25f, y0 + 0.5f * j + 0.25f, static_cast<float>(kGroundZ));
  }
  return out;
}

// The ground alone (no boxes): every patch in front of a camera is in plain view.
BoxScene FlatGround() {
  BoxScene s = PriorScene();
  s.boxes.clear();
  return s;
}

// Tile 0_0 (x, y in [0, 20)): patch "front" at y 2..6, seen from a drive at y = 16 looking -y
// (10..14 m ahead), and patch "back" at y 16..20, behind that drive's cameras.
PointCloud FrontPatch() { return GroundPatch(10, 2); }
PointCloud BackPatch() { return GroundPatch(10, 16); }

ServerConfig CoverageConfigFor(const fs::path& dir) {
  ServerConfig c;
  c.storage.database = (dir / "coverage.db").string();
  c.storage.tile_size_m = 20;
  c.pipeline.max_depth_m = kMaxDepth;
  c.pipeline.free_space_depth_m = 20;
  c.pipeline.pixel_stride = 1;
  c.pipeline.gicp_enabled = false;  // exact poses: the test is about which points were seen
  // The prior is two patches of ground, not a map of the place: under the paper's rule the
  // ground the drives see around them is new, which the refresh test merges into the prior (the
  // confident rule keeps new points to the prior's footprint, so nothing would be merged).
  c.pipeline.free_space = "paper";
  c.classify.th_ch_m = 2.4;
  return c;
}

class Coverage : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    log::SetLevel(log::Level::kWarn);
    dir_ = fs::temp_directory_path() / ("mds_coverage_" + GetParam() + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    config_ = CoverageConfigFor(dir_);
    if (GetParam() != "memory") UseFreshDatabase(GetParam(), dir_, &config_);
    service_ = std::make_unique<MapService>(
        config_, GetParam() == "memory" ? OpenMemoryStorage() : OpenConfiguredStorage(config_));
    PointCloud prior = FrontPatch();
    const PointCloud back = BackPatch();
    prior.insert(prior.end(), back.begin(), back.end());
    const fs::path file = dir_ / "prior.pcd";
    WriteCloud(file.string(), prior);
    service_->ImportPriorFile(file.string(), "two patches");
  }
  void TearDown() override {
    service_.reset();
    fs::remove_all(dir_);
  }

  // A drive along y = y_cam looking -y over the flat ground, committed; created_ms (if given)
  // backdates the session (as a session of that time would be stored).
  int64_t Drive(const std::string& vehicle, double y_cam,
                std::optional<int64_t> created_ms = std::nullopt) {
    int64_t s =
        service_->CreateSession({{"vehicle_id", vehicle}, {"camera", kCamera}})["session_id"];
    if (created_ms) {
      SessionRecord r = *service_->storage().sessions().Get(s);
      r.created_ms = *created_ms;
      s = service_->storage().sessions().Create(r);
    }
    int64_t seq = 0;
    for (double x = -5; x <= 45; x += 2.5, ++seq) {
      const SE3 T = CameraLookingMinusY(x, y_cam, kCameraHeight, kPitch);
      const auto png = EncodeDepthPng(FlatGround().Render(TestCamera(), T, kMaxDepth));
      bool created = false;
      service_->PutKeyframe(s, seq, MetaJson(1000000000LL * (seq + 1), T),
                            Bytes(png.begin(), png.end()), &created);
    }
    const int64_t job = service_->CommitSession(s)["job_id"];
    service_->RunQueuedJobsNow();
    EXPECT_EQ(service_->GetJob(job)["state"], "succeeded") << service_->GetJob(job).dump(2);
    return s;
  }

  ObservedArea Octree(int64_t session) {
    const auto blob = service_->storage().sessions().GetObserved(session);
    EXPECT_TRUE(blob);
    return ObservedArea::DeserializeBinary(DecodeObserved(blob.value_or(Bytes{})));
  }
  // The oracle: how many of the points any of the sessions' octrees knows.
  int64_t ObservedByAny(const PointCloud& points, const std::vector<int64_t>& sessions) {
    std::vector<ObservedArea> areas;
    for (int64_t s : sessions) areas.push_back(Octree(s));
    int64_t n = 0;
    for (const Point& p : points) {
      bool seen = false;
      for (const ObservedArea& a : areas) seen = seen || a.IsObserved(p);
      n += seen ? 1 : 0;
    }
    return n;
  }
  PointCloud PriorPoints(const std::string& tile) {
    const int64_t version = *service_->storage().priors().LatestVersion();
    return DecodePoints(
        service_->storage().priors().GetTile(*TileId::FromString(tile), version)->points);
  }
  // The listing's entry of a tile (null if absent).
  Json Listed(const std::string& tile, int64_t days) {
    const Json list = service_->ListCoverageTiles("-100,-100,200,200", days, 1, 1000);
    for (const Json& t : list["tiles"]) {
      if (t["tile"] == tile) return t;
    }
    return nullptr;
  }
  std::string CreatedAt(int64_t session) {
    return service_->GetSession(session)["created_at"].get<std::string>();
  }

  fs::path dir_;
  ServerConfig config_;
  std::unique_ptr<MapService> service_;
};

TEST_P(Coverage, OneSessionObservesHalfOfTheTile) {
  const Json before = Listed("0_0", 30);
  ASSERT_FALSE(before.is_null());
  EXPECT_EQ(before["prior_points"], 128);
  EXPECT_EQ(before["observed_points"], 0);
  EXPECT_TRUE(before["last_observed"].is_null());

  const int64_t s = Drive("car", 16);
  // The oracle agrees with the geometry: the front patch seen whole, the back one not at all.
  ASSERT_EQ(ObservedByAny(FrontPatch(), {s}), 64);
  ASSERT_EQ(ObservedByAny(BackPatch(), {s}), 0);

  const Json t = Listed("0_0", 30);
  EXPECT_EQ(t["prior_points"], 128);
  EXPECT_EQ(t["observed_points"], 64);
  EXPECT_DOUBLE_EQ(t["fraction"].get<double>(), 0.5);
  EXPECT_EQ(t["sessions"], 1);
  EXPECT_EQ(t["vehicles"], 1);
  EXPECT_EQ(t["last_observed"], CreatedAt(s));
  EXPECT_EQ(t["bounds"], Json({0.0, 0.0, 20.0, 20.0}));

  const Json one = service_->GetTileCoverage("0_0", 30);
  EXPECT_EQ(one["observed_points"], 64);
  ASSERT_EQ(one["observations"].size(), 1u);
  EXPECT_EQ(one["observations"][0]["session_id"], s);
  EXPECT_EQ(one["observations"][0]["vehicle_id"], "car");
  EXPECT_EQ(one["observations"][0]["observed_points"], 64);
}

TEST_P(Coverage, TheWindowOfDaysLeavesAnOldSessionOut) {
  const int64_t recent = Drive("car", 16);
  // 40 days ago, a van drove at y = 40: both patches ahead of it (20..38 m).
  const int64_t old = Drive("van", 40, NowMs() - 40 * kDayMs);
  const PointCloud prior = PriorPoints("0_0");
  ASSERT_EQ(ObservedByAny(BackPatch(), {old}), 64);

  const Json month = Listed("0_0", 30);
  EXPECT_EQ(month["observed_points"], ObservedByAny(prior, {recent}));
  EXPECT_EQ(month["observed_points"], 64);
  EXPECT_EQ(month["sessions"], 1);
  EXPECT_EQ(month["vehicles"], 1);
  EXPECT_EQ(month["last_observed"], CreatedAt(recent));

  const Json two_months = Listed("0_0", 60);
  EXPECT_EQ(two_months["observed_points"], ObservedByAny(prior, {recent, old}));
  EXPECT_EQ(two_months["observed_points"], 128);
  EXPECT_DOUBLE_EQ(two_months["fraction"].get<double>(), 1.0);
  EXPECT_EQ(two_months["sessions"], 2);
  EXPECT_EQ(two_months["vehicles"], 2);
  EXPECT_EQ(two_months["last_observed"], CreatedAt(recent));
  EXPECT_EQ(service_->GetTileCoverage("0_0", 60)["observations"].size(), 2u);
}

TEST_P(Coverage, ARefreshThatChangesThePriorRecomputesTheCoverage) {
  const int64_t a = Drive("car", 16);
  const int64_t b = Drive("van", 40);
  const int64_t v1 = *service_->storage().priors().LatestVersion();
  const int64_t job =
      service_->CreateJob({{"type", "refresh"}, {"bbox", {-100, -100, 200, 200}}})["job_id"];
  service_->RunQueuedJobsNow();
  const Json done = service_->GetJob(job);
  ASSERT_EQ(done["state"], "succeeded") << done.dump(2);
  const int64_t v2 = *service_->storage().priors().LatestVersion();
  ASSERT_GT(v2, v1) << "the refresh merged nothing: " << done.dump(2);
  EXPECT_GT(done["result"]["coverage"]["rows"].get<int64_t>(), 0) << done.dump(2);

  // Tile 0_0 now holds the ground the drives saw as new; its coverage is over those points.
  const PointCloud prior = PriorPoints("0_0");
  ASSERT_GT(prior.size(), 128u);
  const Json t = Listed("0_0", 30);
  EXPECT_EQ(t["prior_points"], static_cast<int64_t>(prior.size()));
  EXPECT_EQ(t["observed_points"], ObservedByAny(prior, {a, b}));
  EXPECT_EQ(t["sessions"], 2);
  // A tile without prior points before the refresh: covered by the same sessions' octrees.
  const Json list = service_->ListCoverageTiles("-100,-100,200,200", 30, 1, 1000);
  int64_t newly_covered = 0;
  for (const Json& tile : list["tiles"]) {
    if (tile["tile"] == "0_0") continue;
    const int64_t expected = ObservedByAny(PriorPoints(tile["tile"]), {a, b});
    EXPECT_EQ(tile["observed_points"], expected) << tile.dump();
    newly_covered += expected > 0 ? 1 : 0;
  }
  EXPECT_GT(newly_covered, 0) << list.dump(2);
  // Every row indexes the points its tile has now.
  for (const CoverageRecord& r :
       service_->storage().coverage().List(Rect{-100, -100, 100, 100}, 0, false)) {
    const auto row = service_->storage().priors().GetTile(r.tile, v2);
    EXPECT_EQ(r.prior_row_version, row ? row->version : 0) << r.tile.ToString();
  }
  // Running the recomputation again (as a resumed job does) finds nothing to do.
  EXPECT_EQ(RecomputeCoverage(service_->storage()).rows, 0);

  // A rollback to the first version copies its points as new rows: recomputed again.
  const int64_t rollback = service_->CreateJob({{"type", "rollback"}, {"version", v1}})["job_id"];
  service_->RunQueuedJobsNow();
  ASSERT_EQ(service_->GetJob(rollback)["state"], "succeeded");
  const Json back = Listed("0_0", 30);
  EXPECT_EQ(back["prior_points"], 128);
  EXPECT_EQ(back["observed_points"], ObservedByAny(PriorPoints("0_0"), {a, b}));
  EXPECT_EQ(back["observed_points"], 128);
  const Json after = service_->ListCoverageTiles("-100,-100,200,200", 30, 1, 1000);
  EXPECT_EQ(after["total"], 1) << "the other tiles are empty again";
}

TEST_P(Coverage, AnImportOfANewPriorRecomputesTheCoverage) {
  const int64_t s = Drive("car", 16);
  // The new prior moves tile 0_0's points: the front patch shifted 4 m in x, still in view.
  const PointCloud moved = GroundPatch(14, 2);
  const fs::path file = dir_ / "moved.pcd";
  WriteCloud(file.string(), moved);
  const Json imported = service_->ImportPriorFile(file.string(), "moved patch");
  EXPECT_GT(imported["coverage_rows_recomputed"].get<int64_t>(), 0) << imported.dump();
  const Json t = Listed("0_0", 30);
  EXPECT_EQ(t["prior_points"], 64);
  EXPECT_EQ(t["observed_points"], ObservedByAny(PriorPoints("0_0"), {s}));
  EXPECT_EQ(t["observed_points"], 64);
  EXPECT_EQ(t["sessions"], 1);
}

TEST_P(Coverage, BadParametersAreRefusedByName) {
  auto refused = [&](auto&& call, const std::string& names) {
    try {
      call();
      ADD_FAILURE() << "accepted; expected a refusal naming " << names;
    } catch (const ApiError& e) {
      EXPECT_EQ(e.code(), ApiCode::kInvalidArgument) << e.what();
      EXPECT_NE(std::string(e.what()).find(names), std::string::npos) << e.what();
    }
  };
  refused([&] { service_->ListCoverageTiles("0,0,10,10", 0, 1, 10); }, "days");
  refused([&] { service_->ListCoverageTiles("0,0,10,10", 3651, 1, 10); }, "days");
  refused([&] { service_->ListCoverageTiles("0,0,10", 30, 1, 10); }, "bbox");
  refused([&] { service_->ListCoverageTiles("10,0,0,10", 30, 1, 10); }, "bbox");
  refused([&] { service_->ListCoverageTiles("0,0,10,10", 30, 0, 10); }, "page");
  refused([&] { service_->ListCoverageTiles("0,0,10,10", 30, 1, 1001); }, "page_size");
  refused([&] { service_->GetTileCoverage("a_b", 30); }, "tile");
  refused([&] { service_->GetTileCoverage("0_0", -1); }, "days");
  try {
    service_->GetTileCoverage("7_7", 30);
    ADD_FAILURE() << "a tile without prior points has no coverage";
  } catch (const ApiError& e) {
    EXPECT_EQ(e.code(), ApiCode::kNotFound) << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(Backends, Coverage, ::testing::Values("memory", "sqlite", "postgres"),
                         [](const auto& info) { return info.param; });

// The routes over HTTP: 400 for what the facade refuses and for what only the adapter sees
// (a non-integer, an unknown parameter, a missing bbox); 401 without a token.
class CoverageHttp : public HttpServerTest {};

TEST_F(CoverageHttp, RoutesAnswerAndRefuseBadParametersWith400) {
  PointCloud prior = FrontPatch();
  const fs::path file = dir_ / "prior.pcd";
  WriteCloud(file.string(), prior);
  service_->ImportPriorFile(file.string(), "front patch");

  auto [status, body] = Call(client_->Get("/v1/coverage/tiles?bbox=-50,-50,50,50", H(reader_)));
  ASSERT_EQ(status, 200) << body.dump();
  EXPECT_EQ(body["days"], 30);
  EXPECT_EQ(body["total"], 1);
  ASSERT_EQ(body["tiles"].size(), 1u);
  EXPECT_EQ(body["tiles"][0]["tile"], "0_0");
  EXPECT_EQ(body["tiles"][0]["observed_points"], 0);
  auto [one_status, one] = Call(client_->Get("/v1/coverage/tiles/0_0?days=7", H(reader_)));
  EXPECT_EQ(one_status, 200) << one.dump();
  EXPECT_EQ(one["days"], 7);

  for (const std::string path :
       {"/v1/coverage/tiles", "/v1/coverage/tiles?bbox=0,0,1",
        "/v1/coverage/tiles?bbox=0,0,1,1&days=x", "/v1/coverage/tiles?bbox=0,0,1,1&days=0",
        "/v1/coverage/tiles?bbox=0,0,1,1&days=99999", "/v1/coverage/tiles?bbox=0,0,1,1&page=0",
        "/v1/coverage/tiles?bbox=0,0,1,1&color=red", "/v1/coverage/tiles/0_0?days=1.5",
        "/v1/coverage/tiles/0_0?bbox=0,0,1,1"}) {
    auto [s, b] = Call(client_->Get(path, H(reader_)));
    EXPECT_EQ(s, 400) << path << ": " << b.dump();
  }
  EXPECT_EQ(Call(client_->Get("/v1/coverage/tiles/3_3", H(reader_))).first, 404);
  EXPECT_EQ(Call(client_->Get("/v1/coverage/tiles?bbox=0,0,1,1")).first, 401);
}

}  // namespace
}  // namespace mapdelta::server
