// Foundation types: tiling, camera round trip, voxel grid, neighbour queries, IO round trips.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/keyframes.hpp"
#include "mapdelta/common/neighbor_index.hpp"
#include "mapdelta/common/tiling.hpp"
#include "mapdelta/common/trajectory_io.hpp"
#include "mapdelta/common/voxel_grid.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta {
namespace {

std::string TempDir(const std::string& name) {
  return mapdelta::testing::FreshTempDir("mapdelta_test_" + name).string();
}

TEST(Tiling, KeysAtNegativeCoordinatesAndBorders) {
  const TileGrid grid(50.0);
  EXPECT_EQ(grid.TileOf(0.0, 0.0), TileId(0, 0));
  EXPECT_EQ(grid.TileOf(49.999, 0.0), TileId(0, 0));
  EXPECT_EQ(grid.TileOf(50.0, 0.0), TileId(1, 0));
  EXPECT_EQ(grid.TileOf(-0.001, -50.0), TileId(-1, -1));
  EXPECT_EQ(grid.TileOf(-50.001, 0.0), TileId(-2, 0));
  const auto box = grid.Bounds(TileId(-2, 3));
  EXPECT_FLOAT_EQ(box.min.x(), -100.f);
  EXPECT_FLOAT_EQ(box.max.y(), 200.f);
}

TEST(Tiling, StringRoundTripAndRejectsGarbage) {
  for (const TileId id : {TileId(0, 0), TileId(-3, 7), TileId(12, -1)}) {
    EXPECT_EQ(TileId::FromString(id.ToString()), id);
  }
  for (const char* bad : {"", "_", "1_", "_2", "1-2", "1_2_3", "a_b", "1_ 2", "99999999999_0"}) {
    EXPECT_FALSE(TileId::FromString(bad).has_value()) << bad;
  }
}

TEST(Camera, ProjectBackProjectRoundTrip) {
  const PinholeCamera camera;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, camera.width), v(0, camera.height), z(0.5, 80);
  for (int i = 0; i < 1000; ++i) {
    const double uu = u(rng), vv = v(rng), zz = z(rng);
    const auto pixel = camera.Project(camera.BackProject(uu, vv, zz));
    ASSERT_TRUE(pixel.has_value());
    EXPECT_NEAR(pixel->x(), uu, 1e-9);
    EXPECT_NEAR(pixel->y(), vv, 1e-9);
  }
  EXPECT_FALSE(camera.Project({0, 0, -1}).has_value());
}

TEST(VoxelGrid, OnePointPerVoxelAtCentroid) {
  const PointCloud cloud = {
      {0.1f, 0.1f, 0.1f}, {0.3f, 0.3f, 0.3f}, {1.1f, 0.1f, 0.1f}, {-0.1f, 0.1f, 0.1f}};
  const PointCloud out = VoxelDownsample(cloud, 0.5f);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_TRUE(out[0].isApprox(Point(0.2f, 0.2f, 0.2f)));
}

TEST(NeighborIndex, AgreesWithBruteForce) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> coord(-20, 20);
  PointCloud cloud(5000), queries(200);
  for (auto& p : cloud) p = {coord(rng), coord(rng), coord(rng)};
  for (auto& p : queries) p = {coord(rng), coord(rng), coord(rng)};
  const NeighborIndex index(cloud);
  const auto distances = index.NearestDistances(queries, 2);
  for (size_t q = 0; q < queries.size(); ++q) {
    float best = 1e9f;
    size_t within = 0;
    for (const auto& p : cloud) {
      best = std::min(best, (p - queries[q]).norm());
      within += (p - queries[q]).norm() <= 2.0f ? 1 : 0;
    }
    EXPECT_NEAR(distances[q], best, 1e-4);
    EXPECT_EQ(index.RadiusSearch(queries[q], 2.0f).size(), within);
  }
}

TEST(CloudIo, PcdAndPlyRoundTrip) {
  const std::string dir = TempDir("cloud_io");
  const PointCloud cloud = {{1, 2, 3}, {-4.5f, 0.25f, 100}};
  for (const char* name : {"/a.pcd", "/a.ply"}) {
    WriteCloud(dir + name, cloud);
    const PointCloud back = ReadCloud(dir + name);
    ASSERT_EQ(back.size(), cloud.size());
    EXPECT_TRUE(back[1].isApprox(cloud[1]));
  }
}

TEST(CloudIo, BadInputNamesTheFile) {
  const std::string dir = TempDir("cloud_io_bad");
  try {
    ReadCloud(dir + "/missing.pcd");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.pcd"), std::string::npos);
  }
  std::ofstream(dir + "/garbage.pcd") << "this is not a pcd file\n";
  EXPECT_THROW(ReadCloud(dir + "/garbage.pcd"), Error);
  EXPECT_THROW(ReadCloud(dir + "/cloud.xyz"), Error);
}

TEST(TrajectoryIo, TumRoundTripAndLineErrors) {
  const std::string dir = TempDir("traj");
  Trajectory trajectory;
  for (int i = 0; i < 5; ++i) {
    trajectory.push_back(
        {1'400'000'000'123'456'789LL + i * 50'000'000LL,
         MakeSE3(Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d::UnitZ())),
                 {1.0 * i, -2.0, 0.5})});
  }
  WriteTumTrajectory(dir + "/t.txt", trajectory);
  const Trajectory back = ReadTumTrajectory(dir + "/t.txt");
  ASSERT_EQ(back.size(), trajectory.size());
  EXPECT_EQ(back[3].t_ns, trajectory[3].t_ns);
  EXPECT_TRUE(back[3].T.isApprox(trajectory[3].T, 1e-6));

  std::ofstream(dir + "/bad.txt") << "0 0 0 0 0 0 0 1\n1 0 0 zero 0 0 0 1\n";
  try {
    ReadTumTrajectory(dir + "/bad.txt");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.txt:2"), std::string::npos) << e.what();
  }
}

TEST(Keyframes, FolderRoundTripAndSizeMismatch) {
  const std::string dir = TempDir("keyframes");
  KeyframeFolder folder;
  folder.camera.width = 8;
  folder.camera.height = 6;
  Keyframe keyframe;
  keyframe.t_ns = 1000;
  keyframe.T_map_cam.translation() = Eigen::Vector3d(1, 2, 3);
  keyframe.depth = DepthImage(8, 6);
  keyframe.depth.at(2, 3) = 12.345f;
  Matrix6d covariance = Matrix6d::Identity() * 0.01;
  covariance(0, 5) = 0.002;
  keyframe.covariance = covariance;
  folder.keyframes.push_back(keyframe);
  WriteKeyframeFolder(dir, folder);
  const KeyframeFolder back = ReadKeyframeFolder(dir);
  ASSERT_EQ(back.keyframes.size(), 1u);
  EXPECT_NEAR(back.keyframes[0].depth.at(2, 3), 12.345f, 1e-3);
  EXPECT_TRUE(back.keyframes[0].covariance->isApprox(covariance));
  EXPECT_TRUE(back.keyframes[0].T_map_cam.isApprox(keyframe.T_map_cam));

  WriteDepthPng(dir + "/depth/1000.png", DepthImage(9, 6));
  EXPECT_THROW(ReadKeyframeFolder(dir), Error);
}

}  // namespace
}  // namespace mapdelta
