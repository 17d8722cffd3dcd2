// The commit job's fast path against its simple path, and the per-tile .bt download.
//
// Fast path: session cloud from the clouds stored at upload, observed octrees built on two
// threads in chunks of 4 keyframes and merged. Simple path: one chunk, i.e. one octree for
// the whole session built on one thread, and every keyframe cloud recomputed from its PNG
// (the clouds were stored with other parameters, so the commit must not use them). Both must give
// byte-identical aggregates and changes and octrees that know exactly the same voxels.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "blob_codec.hpp"
#include "box_scene.hpp"
#include "changed_scene.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/observed_area.hpp"
#include "mapdelta/server/map_service.hpp"
#include "sqlite_db.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta::server {
namespace {

using namespace mapdelta::testing;  // NOLINT: the shared test scene
namespace fs = std::filesystem;

ServerConfig Config(const fs::path& db) {
  ServerConfig c;
  c.storage.database = db.string();
  c.storage.tile_size_m = 20;
  c.pipeline.max_depth_m = kMaxDepth;
  c.pipeline.free_space_depth_m = 20;
  c.pipeline.pixel_stride = 1;
  c.classify.th_ch_m = 2.4;
  return c;
}

const Json kCamera{{"width", 160}, {"height", 90}, {"fx", 80}, {"fy", 80}, {"cx", 80}, {"cy", 45}};

// Imports the prior and uploads one drive over the changed scene; returns the session id.
int64_t ImportAndUpload(MapService& service, const fs::path& dir) {
  const std::string prior = (dir / "prior.pcd").string();
  WriteCloud(prior, PriorScene().Sample(0.4));
  service.ImportPriorFile(prior, "test");
  const int64_t s =
      service.CreateSession({{"vehicle_id", "car"}, {"camera", kCamera}})["session_id"];
  const BoxScene scene = ChangedScene();
  int64_t seq = 0;
  for (double x = -5; x <= 45; x += 2.5, ++seq) {
    const SE3 T = CameraLookingMinusY(x, 25.0, kCameraHeight, kPitch);
    const auto png = EncodeDepthPng(scene.Render(TestCamera(), T, kMaxDepth));
    bool stored = false;
    service.PutKeyframe(s, seq, MetaJson(1000000000LL * (seq + 1), T),
                        Bytes(png.begin(), png.end()), &stored);
  }
  return s;
}

Json CommitAndRun(MapService& service, int64_t session) {
  const int64_t job = service.CommitSession(session)["job_id"];
  service.RunQueuedJobsNow();
  return service.GetJob(job);
}

class CommitPaths : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    log::SetLevel(log::Level::kWarn);
    dir_ = new fs::path(FreshTempDir("mds_commit"));
    // Fast path.
    ServerConfig fast_config = Config(*dir_ / "fast.db");
    fast_config.pipeline.threads = 2;
    fast_config.pipeline.chunk_keyframes = 4;
    fast_ = new MapService(fast_config, OpenSqliteStorage(fast_config.storage.database));
    session_ = ImportAndUpload(*fast_, *dir_);
    fast_job_ = new Json(CommitAndRun(*fast_, session_));
    // Simple path: clouds stored with another voxel size, then committed by a one-thread,
    // one-chunk server with the test's parameters.
    ServerConfig upload_config = Config(*dir_ / "simple.db");
    upload_config.pipeline.session_voxel_m = 0.5;
    int64_t simple_session = 0;
    {
      MapService uploader(upload_config, OpenSqliteStorage(upload_config.storage.database));
      simple_session = ImportAndUpload(uploader, *dir_);
    }
    ServerConfig simple_config = Config(*dir_ / "simple.db");
    simple_config.pipeline.threads = 2;  // GICP sums in threads: same count, same bits
    simple_config.pipeline.chunk_keyframes = 100000;
    simple_ = new MapService(simple_config, OpenSqliteStorage(simple_config.storage.database));
    simple_job_ = new Json(CommitAndRun(*simple_, simple_session));
  }
  static void TearDownTestSuite() {
    delete fast_;
    delete simple_;
    delete fast_job_;
    delete simple_job_;
    fs::remove_all(*dir_);
    delete dir_;
  }

  static fs::path* dir_;
  static MapService* fast_;
  static MapService* simple_;
  static Json* fast_job_;
  static Json* simple_job_;
  static int64_t session_;
};
fs::path* CommitPaths::dir_ = nullptr;
MapService* CommitPaths::fast_ = nullptr;
MapService* CommitPaths::simple_ = nullptr;
Json* CommitPaths::fast_job_ = nullptr;
Json* CommitPaths::simple_job_ = nullptr;
int64_t CommitPaths::session_ = 0;

ObservedArea SessionOctree(MapService& service, int64_t session) {
  const auto blob = service.storage().sessions().GetObserved(session);
  EXPECT_TRUE(blob.has_value());
  return ObservedArea::DeserializeBinary(blob ? DecodeObserved(*blob) : std::string());
}

// Voxel centres (0.8 m octree, boundaries at multiples of 0.8) over the scene, 0.4 m apart so
// every voxel is probed twice per axis.
template <typename Fn>
void ForEachProbe(Fn fn) {
  for (int i = 0; i < 250; ++i) {
    for (int j = 0; j < 135; ++j) {
      for (int k = 0; k < 38; ++k)
        fn(Point(float(-30.2 + 0.4 * i), float(-12.2 + 0.4 * j), float(-3.0 + 0.4 * k)));
    }
  }
}

TEST_F(CommitPaths, FastPathEqualsSimplePath) {
  ASSERT_EQ((*fast_job_)["state"], "succeeded") << fast_job_->dump(2);
  ASSERT_EQ((*simple_job_)["state"], "succeeded") << simple_job_->dump(2);
  const Json& f = (*fast_job_)["result"];
  const Json& s = (*simple_job_)["result"];
  EXPECT_EQ(f["keyframe_clouds_recomputed"], 0);   // read from upload
  EXPECT_EQ(s["keyframe_clouds_recomputed"], 21);  // stale: recomputed from the PNGs
  EXPECT_EQ(f["registration"], s["registration"]);
  EXPECT_EQ(f["session_points"], s["session_points"]);
  EXPECT_EQ(f["tiles_aggregated"], s["tiles_aggregated"]);
  EXPECT_EQ(f["tiles_classified"], s["tiles_classified"]);
  EXPECT_GT(f["new_points"].get<int>(), 0);
  // A committed session's upload-time clouds are dropped (derived data, as large as the PNGs).
  size_t clouds = 0;
  fast_->storage().sessions().ForEachKeyframe(
      session_, 0, 1000, false, [&](const KeyframeRecord& k) { clouds += !k.cloud.empty(); });
  EXPECT_EQ(clouds, 0u);
  EXPECT_GT(f["removed_points"].get<int>(), 0);

  // Aggregates and changes, tile by tile, byte for byte (changes decoded for a readable diff).
  const auto tiles = fast_->storage().tiles().ListAggregated(std::nullopt);
  ASSERT_EQ(tiles, simple_->storage().tiles().ListAggregated(std::nullopt));
  ASSERT_GE(tiles.size(), 3u);
  for (const TileId& t : tiles) {
    SCOPED_TRACE(t.ToString());
    EXPECT_EQ(fast_->storage().tiles().GetState(t)->aggregate,
              simple_->storage().tiles().GetState(t)->aggregate);
    const auto fc = fast_->storage().tiles().GetChanges(t),
               sc = simple_->storage().tiles().GetChanges(t);
    ASSERT_TRUE(fc && sc);
    const auto a = DecodeChanges(fc->changes), b = DecodeChanges(sc->changes);
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].position, b[i].position);
      EXPECT_EQ(a[i].kind, b[i].kind);
      EXPECT_EQ(a[i].confidence, b[i].confidence);
      EXPECT_EQ(a[i].observed_by, b[i].observed_by);
      EXPECT_EQ(a[i].supported_by, b[i].supported_by);
    }
  }

  // The octrees know the same voxels (log-odds may differ: clamped sums depend on order).
  const ObservedArea fo = SessionOctree(*fast_, session_);
  const ObservedArea so = SessionOctree(*simple_, session_);
  size_t known = 0, differ = 0;
  ForEachProbe([&](const Point& p) {
    const bool a = fo.IsObserved(p);
    known += a;
    differ += a != so.IsObserved(p);
  });
  EXPECT_EQ(differ, 0u);
  EXPECT_GT(known, 10000u);
}

TEST_F(CommitPaths, ObservedTileDownloadHoldsThatTileOnly) {
  const ObservedArea whole = SessionOctree(*fast_, session_);
  const auto tiles = fast_->storage().tiles().ListAggregated(std::nullopt);
  ASSERT_GE(tiles.size(), 3u);
  for (const TileId& id : tiles) {
    const std::string tile = id.ToString();
    SCOPED_TRACE(tile);
    const FilePayload bt = fast_->GetObservedTile(tile);
    ASSERT_EQ(std::string(bt.bytes.begin(), bt.bytes.begin() + 28), "# Octomap OcTree binary file");
    const ObservedArea cut =
        ObservedArea::DeserializeBinary(std::string(bt.bytes.begin(), bt.bytes.end()));
    const AxisAlignedBox b = TileGrid(20).Bounds(id);
    size_t inside = 0, outside_known_in_whole = 0, mismatches = 0, leaks = 0;
    ForEachProbe([&](const Point& p) {
      if (p.x() > b.min.x() && p.x() < b.max.x() && p.y() > b.min.y() && p.y() < b.max.y()) {
        inside += whole.IsObserved(p);
        mismatches += whole.IsObserved(p) != cut.IsObserved(p);
        return;
      }
      // The 0.8 m voxel holding p: if it does not overlap the tile, the download must not
      // know it.
      const double vx = std::floor(p.x() / 0.8) * 0.8, vy = std::floor(p.y() / 0.8) * 0.8;
      const bool overlaps =
          vx + 0.8 > b.min.x() && vx < b.max.x() && vy + 0.8 > b.min.y() && vy < b.max.y();
      if (overlaps) return;
      outside_known_in_whole += whole.IsObserved(p);
      leaks += cut.IsObserved(p);
    });
    EXPECT_EQ(mismatches, 0u);
    EXPECT_EQ(leaks, 0u);
    EXPECT_GT(outside_known_in_whole, 1000u);  // the crop had something to remove
    if (tile == "0_0" || tile == "1_0") {
      EXPECT_GT(inside, 1000u);
    }
  }
  EXPECT_THROW(fast_->GetObservedTile("40_40"), ApiError);  // never observed: 404
}

// A refresh killed after writing its version (state left 'running', neighbours not yet
// reclassified) resumes by reclassifying the neighbours against that version; it does not
// make a second version. Runs last: it changes the fast database.
TEST_F(CommitPaths, RefreshResumedAfterItsVersionFinishesWithoutASecondVersion) {
  const Json job = fast_->CreateJob(
      {{"type", "refresh"}, {"bbox", {-30, -10, 70, 40}}, {"min_confidence", 0.6}});
  fast_->RunQueuedJobsNow();
  const int64_t id = job["job_id"];
  const Json done = fast_->GetJob(id);
  ASSERT_EQ(done["state"], "succeeded") << done.dump(2);
  ASSERT_EQ(fast_->storage().priors().ListVersions().size(), 2u);
  // Classifications after the refresh: the neighbours of refreshed tiles against version 2
  // (step 3), tiles farther away keep their version-1 result (their prior did not change).
  std::map<std::string, std::pair<int64_t, Bytes>> after;
  size_t redone = 0;
  for (const TileId& t : fast_->storage().tiles().ListAggregated(std::nullopt)) {
    const auto c = fast_->storage().tiles().GetChanges(t);
    ASSERT_TRUE(c);
    after[t.ToString()] = {c->prior_version, c->changes};
    redone += c->prior_version == 2;
  }
  ASSERT_GE(redone, 1u);
  // Simulate the crash between the version's transaction and the neighbours' one.
  {
    sql::Db db((*dir_ / "fast.db").string());
    db.Exec("UPDATE jobs SET state = 'running', finished_ms = NULL WHERE id = " +
            std::to_string(id));
    db.Exec("UPDATE tile_changes SET prior_version = 1, changes = x'' WHERE prior_version = 2");
  }
  EXPECT_EQ(fast_->storage().jobs().RequeueInterrupted(NowMs()), 1);
  fast_->RunQueuedJobsNow();
  const Json resumed = fast_->GetJob(id);
  ASSERT_EQ(resumed["state"], "succeeded") << resumed.dump(2);
  EXPECT_EQ(resumed["result"]["resumed"], true);
  EXPECT_EQ(resumed["result"]["prior_version"], 2);
  EXPECT_EQ(fast_->storage().priors().ListVersions().size(), 2u);
  for (const auto& [tile, expected] : after) {
    const auto c = fast_->storage().tiles().GetChanges(*TileId::FromString(tile));
    ASSERT_TRUE(c);
    EXPECT_EQ(c->prior_version, expected.first) << tile;
    EXPECT_EQ(c->changes, expected.second) << tile;
  }
}

}  // namespace
}  // namespace mapdelta::server
