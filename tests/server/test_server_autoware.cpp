// Autoware grid map interop: export-autoware's folder (tile PCDs + pointcloud_map_metadata.yaml)
// and import-prior reading such a folder, through the facade on the in-memory storage, on the
// shared box scene. Round trip: the same points (as a set, float32) after export + import; the
// metadata agrees with the tiles; bad folders are refused naming the file, storing nothing.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "autoware_map.hpp"
#include "autoware_metadata.hpp"
#include "autoware_projector.hpp"
#include "blob_codec.hpp"
#include "changed_scene.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/map_service.hpp"
#include "mapdelta/server/memory_storage.hpp"
#include "prior_points.hpp"

namespace mapdelta::server {
namespace {

namespace fs = std::filesystem;
using testing::PointSet;
using testing::PriorPoints;
using testing::ToSet;

fs::path TempDir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("mds_autoware_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

struct AutowareFixture : ::testing::Test {
  void SetUp() override {
    log::SetLevel(log::Level::kWarn);
    config.storage.tile_size_m = 20;
    service = std::make_unique<MapService>(config, OpenMemoryStorage());
    dir = TempDir(::testing::UnitTest::GetInstance()->current_test_info()->name());
    // 0.5 m spacing from x = -30, y = -10: many points lie exactly on tile edges (0, 20, ...).
    scene = testing::PriorScene().Sample(0.5);
    WriteCloud((dir / "prior.pcd").string(), scene);
    service->ImportPriorFile((dir / "prior.pcd").string(), "box scene");
  }
  void TearDown() override { fs::remove_all(dir); }

  // Exports version 1 into dir/name and returns that folder.
  fs::path Export(const std::string& name, double tile_size_m) {
    ExportAutowareMap(service->storage().priors(), 1, tile_size_m, (dir / name).string(),
                      service->Frame());
    return dir / name;
  }

  // Importing `folder` fails with invalid_argument naming `expected`, and stores nothing.
  void ExpectRefused(const fs::path& folder, const std::string& expected) {
    const auto before = service->storage().priors().LatestVersion();
    try {
      service->ImportPriorFile(folder.string(), "bad");
      ADD_FAILURE() << "accepted " << folder;
    } catch (const ApiError& e) {
      EXPECT_EQ(e.code(), ApiCode::kInvalidArgument);
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos)
          << "message: " << e.what() << "\nexpected to contain: " << expected;
    }
    EXPECT_EQ(service->storage().priors().LatestVersion(), before);
    EXPECT_EQ(PriorPoints(*service, *before), ToSet(scene));
  }

  ServerConfig config;
  std::unique_ptr<MapService> service;
  fs::path dir;
  PointCloud scene;
};

TEST_F(AutowareFixture, ExportThenImportGivesTheSamePoints) {
  ASSERT_EQ(PriorPoints(*service, 1), ToSet(scene));
  const fs::path out = Export("map", config.storage.tile_size_m);
  const Json imported = service->ImportPriorFile(out.string(), "from autoware");
  EXPECT_EQ(imported["prior_version"], 2);
  EXPECT_EQ(imported["points"], scene.size());
  EXPECT_EQ(PriorPoints(*service, 2), ToSet(scene));
  // A second round trip through another tile size (not a divisor of the store's) too.
  const fs::path regridded = Export("map_12.5", 12.5);
  service->ImportPriorFile(regridded.string(), "regridded");
  EXPECT_EQ(PriorPoints(*service, 3), ToSet(scene));
}

TEST_F(AutowareFixture, MetadataListsEveryTileWithItsBox) {
  for (const double size : {20.0, 12.5}) {
    const fs::path out = Export("map_" + std::to_string(size), size);
    const AutowareMetadata m =
        ParseAutowareMetadata(ReadText(out / kAutowareMetadataFile), "metadata");
    EXPECT_EQ(m.x_resolution, size);
    EXPECT_EQ(m.y_resolution, size);
    std::set<std::string> listed;
    size_t points = 0;
    for (const AutowareTileEntry& t : m.tiles) {
      SCOPED_TRACE(t.file);
      EXPECT_TRUE(listed.insert(t.file).second);
      EXPECT_EQ(t.file, AutowareTileFileName(t.x_min, t.y_min));
      EXPECT_EQ(std::fmod(t.x_min, size), 0.0);
      EXPECT_EQ(std::fmod(t.y_min, size), 0.0);
      const std::string text = ReadText(out / t.file);
      EXPECT_NE(text.find("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"), std::string::npos);
      EXPECT_NE(text.find("DATA binary\n"), std::string::npos);
      const PointCloud cloud = ReadCloud((out / t.file).string());
      EXPECT_FALSE(cloud.empty());
      for (const Point& p : cloud) {  // strictly inside [min, min + size), no tolerance
        ASSERT_TRUE(p.x() >= t.x_min && p.x() < t.x_min + size) << p.transpose();
        ASSERT_TRUE(p.y() >= t.y_min && p.y() < t.y_min + size) << p.transpose();
      }
      points += cloud.size();
    }
    EXPECT_EQ(points, scene.size());
    std::set<std::string> files;
    for (const auto& e : fs::directory_iterator(out)) files.insert(e.path().filename().string());
    files.erase(kAutowareMetadataFile);
    // The map's frame beside the tiles: this map is local (origin 0, no CRS).
    EXPECT_EQ(files.erase(kAutowareProjectorFile), 1u);
    EXPECT_NE(ReadText(out / kAutowareProjectorFile).find("projector_type: Local"),
              std::string::npos);
    EXPECT_EQ(files, listed);  // nothing written that the metadata does not list
  }
  // The scene spans x [-30, 70), y [-10, 40): tiles of 20 m from x -40 to 80, y -20 to 40.
  const AutowareMetadata m =
      ParseAutowareMetadata(ReadText(dir / "map_20.000000" / kAutowareMetadataFile), "metadata");
  EXPECT_EQ(m.tiles.size(), 6u * 3u);
  EXPECT_EQ(m.tiles.front().file, "pointcloud_map_-40_-20.pcd");
  EXPECT_EQ(AutowareTileFileName(-37.5, 12.5), "pointcloud_map_-37.5_12.5.pcd");
}

TEST_F(AutowareFixture, MissingTileFileIsRefusedNamingIt) {
  const fs::path out = Export("map", 20);
  fs::remove(out / "pointcloud_map_0_0.pcd");
  ExpectRefused(out, "pointcloud_map_0_0.pcd: listed in");
}

TEST_F(AutowareFixture, MalformedMetadataIsRefusedNamingTheFileAndKey) {
  const fs::path out = Export("map", 20);
  const fs::path metadata = out / kAutowareMetadataFile;
  const std::string good = ReadText(metadata);
  WriteText(metadata, "x_resolution: [20\n");
  ExpectRefused(out, std::string(kAutowareMetadataFile) + ": not valid YAML");
  WriteText(metadata, "y_resolution: 20\npointcloud_map_0_0.pcd: [0, 0]\n");
  ExpectRefused(out, "x_resolution: missing");
  WriteText(metadata, "x_resolution: -20\ny_resolution: 20\n");
  ExpectRefused(out, "x_resolution: expected a positive number");
  WriteText(metadata, good + "pointcloud_map_x.pcd: [0]\n");
  ExpectRefused(out, "pointcloud_map_x.pcd: expected [x_min, y_min]");
  WriteText(metadata, good + "pointcloud_map_x.pcd: [0, abc]\n");
  ExpectRefused(out, "pointcloud_map_x.pcd[1]: expected a finite number");
  WriteText(metadata, good + "../prior.pcd: [0, 0]\n");
  ExpectRefused(out, "../prior.pcd: expected a file name inside the folder");
  WriteText(metadata, "x_resolution: 20\ny_resolution: 20\n");
  ExpectRefused(out, "no tile entries");
  fs::remove(metadata);
  ExpectRefused(out, "no pointcloud_map_metadata.yaml");
}

TEST_F(AutowareFixture, PointOutsideItsTileBoxIsRefusedNamingTheFile) {
  const fs::path out = Export("map", 20);
  const fs::path tile = out / "pointcloud_map_0_0.pcd";
  PointCloud cloud = ReadCloud(tile.string());
  ASSERT_FALSE(cloud.empty());
  cloud.push_back(Point(20.5f, 5.f, 0.f));  // belongs to the tile at x 20
  WriteCloud(tile.string(), cloud);
  ExpectRefused(out, "pointcloud_map_0_0.pcd: point " + std::to_string(cloud.size() - 1) +
                         " (20.5, 5, 0) lies outside the tile's box x in [0, 20)");
  // Within a float32 rounding step of the edge is inside (Autoware's tools write float32).
  cloud.back() = Point(20.0001f, 5.f, 0.f);
  WriteCloud(tile.string(), cloud);
  EXPECT_EQ(service->ImportPriorFile(out.string(), "edge")["prior_version"], 2);
}

TEST_F(AutowareFixture, ExportRefusesAnUnknownVersionAndAFolderInUse) {
  try {
    ExportAutowareMap(service->storage().priors(), 2, 20, (dir / "v2").string(), service->Frame());
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kNotFound);
    EXPECT_FALSE(fs::exists(dir / "v2"));
  }
  // A folder with anything in it is left alone (dir holds prior.pcd).
  try {
    ExportAutowareMap(service->storage().priors(), 1, 20, dir.string(), service->Frame());
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kConflict);
    EXPECT_FALSE(fs::exists(dir / kAutowareMetadataFile));
  }
}

}  // namespace
}  // namespace mapdelta::server
