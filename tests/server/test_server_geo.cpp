// Georeferenced maps (issue #24 item 2): a UTM copy of the box scene, shifted by kUtm, against
// the same scene near (0, 0). The prior round-trips to the millimetre through every download
// format, the changes of the same sessions come back equal but for the shift, and imports that
// would change the map's frame or lose precision are refused with nothing stored.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "autoware_map.hpp"
#include "box_scene.hpp"
#include "changed_scene.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/map_service.hpp"
#include "mapdelta/server/memory_storage.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta::server {
namespace {

using namespace mapdelta::testing;  // NOLINT: the shared test scene
namespace fs = std::filesystem;

// UTM zone 32N easting/northing and a height: float32 would round the northing to 0.5 m.
const Eigen::Vector3d kUtm(500000, 5400000, 100);
const Json kCamera{{"width", 160}, {"height", 90}, {"fx", 80}, {"fy", 80}, {"cx", 80}, {"cy", 45}};

ServerConfig Config() {
  ServerConfig c;
  c.storage.tile_size_m = 20;
  c.pipeline.max_depth_m = kMaxDepth;
  c.pipeline.pixel_stride = 2;
  c.classify.th_ch_m = 2.4;
  return c;
}

std::unique_ptr<MapService> NewService() {
  return std::make_unique<MapService>(Config(), OpenMemoryStorage());
}

// The prior scene's samples in user coordinates: local + offset, written as a float64 PLY.
std::string WritePrior(const fs::path& dir, const Eigen::Vector3d& offset) {
  const std::string path = (dir / "prior.ply").string();
  WriteCloud(path, PriorScene().Sample(0.5), CloudFrame{offset, "EPSG:32632"});
  return path;
}

PrecisePointCloud Shifted(const PointCloud& local, const Eigen::Vector3d& offset) {
  PrecisePointCloud out;
  for (const Point& p : local) out.push_back(p.cast<double>() + offset);
  return out;
}

// Largest distance from a point of `a` to the point of `b` at the same index, after sorting
// both (the clouds hold the same points in possibly another order).
double MaxSortedDistance(PrecisePointCloud a, PrecisePointCloud b) {
  const auto less = [](const PrecisePoint& p, const PrecisePoint& q) {
    return std::lexicographical_compare(p.data(), p.data() + 3, q.data(), q.data() + 3);
  };
  std::sort(a.begin(), a.end(), less);
  std::sort(b.begin(), b.end(), less);
  EXPECT_EQ(a.size(), b.size());
  if (a.size() != b.size()) return 1e9;  // not the same cloud
  double worst = 0;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    worst = std::max(worst, (a[i] - b[i]).cwiseAbs().maxCoeff());
  return worst;
}

PrecisePointCloud ReadPayload(const FilePayload& p, const fs::path& path) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(p.bytes.data()), std::streamsize(p.bytes.size()));
  return ReadCloudPrecise(path.string());
}

// One vehicle drives past the changed scene (box A gone, box C new) and commits. Poses are
// sent in user coordinates; camera positions are whole metres, so pose + offset - origin is
// exact and both runs see bit-identical local poses.
void UploadAndCommit(MapService& service, const Eigen::Vector3d& offset) {
  const int64_t s =
      service.CreateSession({{"vehicle_id", "car"}, {"camera", kCamera}})["session_id"];
  int64_t seq = 0;
  for (double x = -4; x <= 40; x += 2, ++seq) {
    const SE3 T_local = CameraLookingMinusY(x, 30.0, kCameraHeight, kPitch);
    SE3 T_user = T_local;
    T_user.translation() += offset;
    const auto png = EncodeDepthPng(ChangedScene().Render(TestCamera(), T_local, kMaxDepth));
    bool stored = false;
    service.PutKeyframe(s, seq, MetaJson(1000000000LL * (seq + 1), T_user),
                        Bytes(png.begin(), png.end()), &stored);
  }
  const int64_t job = service.CommitSession(s)["job_id"];
  service.RunQueuedJobsNow();
  ASSERT_EQ(service.GetJob(job)["state"], "succeeded") << service.GetJob(job).dump(2);
}

Json TileChanges(MapService& service, const std::string& tile) {
  const FilePayload p = service.GetTileChanges(tile, "json", "", 0, 0);
  return Json::parse(std::string(p.bytes.begin(), p.bytes.end()));
}

class GeoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    log::SetLevel(log::Level::kWarn);
    dir_ = FreshTempDir("mds_geo");
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(GeoTest, UtmPriorRoundTripsToTheMillimetreThroughPlyPcdAndAutoware) {
  auto service = NewService();
  const Json imported = service->ImportPriorFile(WritePrior(dir_, kUtm), "utm");
  // No origin given: the middle of the extent, rounded down to the 20 m tile grid, z kept at
  // 0 (the heights are within the float32 bound).
  EXPECT_EQ(imported["origin_chosen"], true);
  const AxisAlignedBox box = Bounds(PriorScene().Sample(0.5));
  const auto middle_on_grid = [](double lo, double hi) {
    return std::floor((lo + hi) / 2 / 20) * 20;
  };
  const Eigen::Vector3d origin(middle_on_grid(kUtm.x() + box.min.x(), kUtm.x() + box.max.x()),
                               middle_on_grid(kUtm.y() + box.min.y(), kUtm.y() + box.max.y()), 0);
  EXPECT_NEAR(origin.x(), kUtm.x() + 20, 20);
  EXPECT_EQ(imported["frame"]["origin"], Json({origin.x(), origin.y(), origin.z()}));
  EXPECT_EQ(service->Frame().crs, "");
  const PrecisePointCloud truth = Shifted(PriorScene().Sample(0.5), kUtm);

  PrecisePointCloud ply, pcd;
  PointCloud local;
  const Json listing = service->ListPriorTilesNear(kUtm.x() + 20, kUtm.y() + 15, 100, 1);
  ASSERT_GT(listing["tiles"].size(), 4u);
  for (const Json& t : listing["tiles"]) {
    const std::string tile = t["tile"];
    const auto a = ReadPayload(service->GetPriorTile(tile, 1, "ply"), dir_ / "t.ply");
    const auto b = ReadPayload(service->GetPriorTile(tile, 1, "pcd"), dir_ / "t.pcd");
    ply.insert(ply.end(), a.begin(), a.end());
    pcd.insert(pcd.end(), b.begin(), b.end());
    const PointCloud l = ReadCloud((dir_ / "t.pcd").string());  // VIEWPOINT not applied
    local.insert(local.end(), l.begin(), l.end());
    // Bounds are in user coordinates: the tile's box contains its points.
    EXPECT_GE(a.front().x(), t["bounds"][0].get<double>());
    EXPECT_LT(a.front().y(), t["bounds"][3].get<double>());
  }
  EXPECT_LT(MaxSortedDistance(ply, truth), 0.5e-3) << "ply";
  EXPECT_LT(MaxSortedDistance(pcd, truth), 0.5e-3) << "pcd";
  EXPECT_LT(MaxSortedDistance(Shifted(local, origin), truth), 0.5e-3);

  // Autoware: local tiles + map_projector_info.yaml; importing the folder into a new map
  // gives the same frame and the same points.
  const fs::path aw = dir_ / "autoware";
  ExportAutowareMap(service->storage().priors(), 1, 20, aw.string(), service->Frame());
  auto again = NewService();
  const Json reimported = again->ImportPriorFile(aw.string(), "aw");
  EXPECT_EQ(reimported["origin_chosen"], false);
  EXPECT_EQ(reimported["frame"], imported["frame"]) << reimported.dump();
  PrecisePointCloud back;
  const Json again_listing = again->ListPriorTilesNear(kUtm.x() + 20, kUtm.y() + 15, 100, 1);
  for (const Json& t : again_listing["tiles"]) {
    const auto a = ReadPayload(again->GetPriorTile(t["tile"], 1, "ply"), dir_ / "t.ply");
    back.insert(back.end(), a.begin(), a.end());
  }
  EXPECT_LT(MaxSortedDistance(back, truth), 0.5e-3) << "autoware";
}

TEST_F(GeoTest, ChangesOfUtmSessionsEqualTheLocalRunsShiftedByTheOrigin) {
  auto near_zero = NewService(), utm = NewService();
  near_zero->ImportPriorFile(WritePrior(dir_, Eigen::Vector3d::Zero()), "local");
  FrameRequest frame{"EPSG:32632", kUtm};
  utm->ImportPriorFile(WritePrior(dir_, kUtm), "utm", frame);
  EXPECT_EQ(utm->Frame().origin, kUtm);
  UploadAndCommit(*near_zero, Eigen::Vector3d::Zero());
  UploadAndCommit(*utm, kUtm);

  const Json a = near_zero->ListChangedTiles("-100,-100,100,100", 0, 1, 1000);
  const Json b = utm->ListChangedTiles("499900,5399900,500100,5400100", 0, 1, 1000);
  ASSERT_GE(a["total"].get<int>(), 2);
  ASSERT_EQ(a["tiles"].size(), b["tiles"].size());
  size_t compared = 0;
  for (size_t i = 0; i < a["tiles"].size(); ++i) {
    const Json& ta = a["tiles"][i];
    const Json& tb = b["tiles"][i];
    ASSERT_EQ(ta["tile"], tb["tile"]);  // the same local grid
    EXPECT_EQ(ta["new_count"], tb["new_count"]);
    EXPECT_EQ(ta["removed_count"], tb["removed_count"]);
    for (int k = 0; k < 4; ++k)
      EXPECT_NEAR(tb["bounds"][k].get<double>(), ta["bounds"][k].get<double>() + kUtm[k % 2], 1e-3);
    const Json ca = TileChanges(*near_zero, ta["tile"]), cb = TileChanges(*utm, tb["tile"]);
    for (const char* kind : {"new", "removed"}) {
      ASSERT_EQ(ca[kind].size(), cb[kind].size());
      for (size_t j = 0; j < ca[kind].size(); ++j, ++compared) {
        for (int axis = 0; axis < 3; ++axis) {
          EXPECT_NEAR(cb[kind][j]["p"][axis].get<double>(),
                      ca[kind][j]["p"][axis].get<double>() + kUtm[axis], 1e-3);
        }
        EXPECT_EQ(cb[kind][j]["confidence"], ca[kind][j]["confidence"]);
      }
    }
    // The PLY download carries the UTM coordinates themselves (float64).
    const auto ply =
        ReadPayload(utm->GetTileChanges(tb["tile"], "ply", "removed", 0, 0), dir_ / "c.ply");
    ASSERT_EQ(ply.size(), cb["removed"].size());
    for (size_t j = 0; j < ply.size(); ++j)
      EXPECT_NEAR(ply[j].y(), cb["removed"][j]["p"][1].get<double>(), 1e-3);
  }
  EXPECT_GT(compared, 100u);
}

TEST_F(GeoTest, ImportInAnotherFrameIsRefusedAndStoresNothing) {
  auto service = NewService();
  const std::string prior = WritePrior(dir_, kUtm);
  service->ImportPriorFile(prior, "v1", FrameRequest{"EPSG:32632", kUtm});
  const auto refused = [&](const FrameRequest& frame, const std::string& expected) {
    try {
      service->ImportPriorFile(prior, "v2", frame);
      ADD_FAILURE() << "accepted";
    } catch (const ApiError& e) {
      EXPECT_EQ(e.code(), ApiCode::kInvalidArgument);
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
    EXPECT_EQ(service->storage().priors().LatestVersion(), 1);
  };
  refused(FrameRequest{"EPSG:32633", std::nullopt}, "CRS 'EPSG:32633' differs");
  refused(FrameRequest{std::nullopt, kUtm + Eigen::Vector3d(0, 0.01, 0)}, "origin");
  // Agreeing (or unstated) frames add versions in the map's frame.
  EXPECT_EQ(service->ImportPriorFile(prior, "v2")["prior_version"], 2);
  EXPECT_EQ(
      service->ImportPriorFile(prior, "v3", FrameRequest{"EPSG:32632", kUtm})["prior_version"], 3);
}

TEST_F(GeoTest, WhatFloat32CannotKeepToTheMillimetreIsRefused) {
  auto service = NewService();
  // 10 km either side of the origin: beyond the 8192 m that float32 keeps to 0.25 mm.
  PointCloud wide = {Point(-10000, 0, 0), Point(0, 0, 0), Point(10000, 0, 0)};
  const std::string path = (dir_ / "wide.ply").string();
  WriteCloud(path, wide, CloudFrame{kUtm, ""});
  try {
    service->ImportPriorFile(path, "wide", FrameRequest{std::nullopt, kUtm});
    ADD_FAILURE() << "accepted";
  } catch (const ApiError& e) {
    EXPECT_NE(std::string(e.what()).find("more than 8192 m from the map origin"), std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(service->storage().priors().LatestVersion());
  EXPECT_FALSE(service->storage().priors().Frame());

  // A vehicle sending local coordinates to a UTM map is told so, and nothing is stored.
  service->ImportPriorFile(WritePrior(dir_, kUtm), "utm", FrameRequest{"EPSG:32632", kUtm});
  const int64_t s =
      service->CreateSession({{"vehicle_id", "car"}, {"camera", kCamera}})["session_id"];
  const SE3 T_local = CameraLookingMinusY(0, 30, kCameraHeight, kPitch);
  const auto png = EncodeDepthPng(ChangedScene().Render(TestCamera(), T_local, kMaxDepth));
  bool stored = false;
  try {
    service->PutKeyframe(s, 0, MetaJson(1, T_local), Bytes(png.begin(), png.end()), &stored);
    ADD_FAILURE() << "accepted";
  } catch (const ApiError& e) {
    EXPECT_NE(std::string(e.what()).find("from the map origin"), std::string::npos) << e.what();
  }
  EXPECT_EQ(service->GetSession(s)["keyframe_count"], 0);
}

TEST_F(GeoTest, MapEndpointReportsFrameExtentAndVersion) {
  auto service = NewService();
  Json map = service->GetMap();
  EXPECT_EQ(map["crs"], "");
  EXPECT_TRUE(map["prior_version"].is_null());
  EXPECT_TRUE(map["extent"].is_null());
  service->ImportPriorFile(WritePrior(dir_, kUtm), "utm", FrameRequest{"EPSG:32632", kUtm});
  map = service->GetMap();
  EXPECT_EQ(map["crs"], "EPSG:32632");
  EXPECT_EQ(map["origin"], Json({kUtm.x(), kUtm.y(), kUtm.z()}));
  EXPECT_EQ(map["prior_version"], 1);
  // The ground spans x [-30, 70), y [-10, 40) around the origin: 20 m tiles from x -40 to 80,
  // y -20 to 40 (as test_server_autoware finds them).
  EXPECT_EQ(map["extent"], Json({kUtm.x() - 40, kUtm.y() - 20, kUtm.x() + 80, kUtm.y() + 40}));
  EXPECT_EQ(map["local_limit_m"], 8192);
}

}  // namespace
}  // namespace mapdelta::server
