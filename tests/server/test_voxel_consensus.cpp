// Voxel consensus (server/src/voxel_consensus.hpp): a voxel k sessions filled is left out when
// k other sessions were there without filling it: their octree knows the place, or they filled a
// voxel within reach of it.
#include <gtest/gtest.h>

#include <set>

#include "voxel_consensus.hpp"

namespace mapdelta::server {
namespace {

AggregateVoxel Voxel(float x, float y, float z, std::vector<int64_t> sessions) {
  AggregateVoxel v;
  v.centroid = Point(x, y, z);
  v.point_count = static_cast<uint32_t>(sessions.size());
  v.sessions = std::move(sessions);
  return v;
}

// Octrees as a table: which sessions know which voxel (by its x).
SessionObserves Knows(std::set<std::pair<int64_t, float>> known) {
  return [known = std::move(known)](int64_t s, const Point& p) {
    return known.count({s, p.x()}) > 0;
  };
}

std::vector<char> Keep(const std::vector<AggregateVoxel>& voxels,
                       const std::vector<int64_t>& sessions, const SessionObserves& observes,
                       double reach_m = 1.0) {
  std::vector<const AggregateVoxel*> pointers;
  PointCloud centroids;
  for (const AggregateVoxel& v : voxels) {
    pointers.push_back(&v);
    centroids.push_back(v.centroid);
  }
  return VoxelsWithConsensus(pointers, centroids, sessions, observes, reach_m, /*threads=*/2);
}

TEST(VoxelConsensus, OneSessionAloneKeepsEveryVoxel) {
  const std::vector<AggregateVoxel> voxels = {Voxel(0, 0, 0, {1}), Voxel(0.5f, 0, 0, {1})};
  EXPECT_EQ(Keep(voxels, {1}, Knows({{1, 0.f}, {1, 0.5f}})), (std::vector<char>{1, 1}));
}

// Session 1's point behind a wall (x = 0.6) that sessions 2 and 3 filled at x = 0: their octrees
// end at the wall and never see the place, but they were right beside it.
TEST(VoxelConsensus, AVoxelBesideOtherSessionsSurfaceIsLeftOut) {
  const std::vector<AggregateVoxel> voxels = {Voxel(0, 0, 0, {1, 2, 3}), Voxel(0.6f, 0, 0, {1})};
  const auto keep = Keep(voxels, {1, 2, 3}, Knows({}));
  EXPECT_EQ(keep, (std::vector<char>{1, 0}));
  // Without the reach only the octrees count: nobody else knows the place, so it stays.
  EXPECT_EQ(Keep(voxels, {1, 2, 3}, Knows({}), /*reach_m=*/0), (std::vector<char>{1, 1}));
}

TEST(VoxelConsensus, OtherSessionsOctreesCountAsThere) {
  // Session 1's ghost at x = 5, seen by sessions 2 and 3's octrees: left out.
  const std::vector<AggregateVoxel> voxels = {Voxel(5, 0, 0, {1})};
  EXPECT_EQ(Keep(voxels, {1, 2, 3}, Knows({{2, 5.f}, {3, 5.f}})), (std::vector<char>{0}));
  // Two filled it, one other knows it: kept.
  const std::vector<AggregateVoxel> shared = {Voxel(5, 0, 0, {1, 3})};
  EXPECT_EQ(Keep(shared, {1, 2, 3}, Knows({{2, 5.f}})), (std::vector<char>{1}));
}

// Evidence split evenly goes to the newer sessions: a place that changed between the drives.
TEST(VoxelConsensus, ATieGoesToTheNewerSessions) {
  // Sessions 3 and 4 filled it, the older 1 and 2 saw it empty: the world changed, kept.
  const std::vector<AggregateVoxel> back = {Voxel(5, 0, 0, {3, 4})};
  EXPECT_EQ(Keep(back, {1, 2, 3, 4}, Knows({{1, 5.f}, {2, 5.f}})), (std::vector<char>{1}));
  // Sessions 1 and 2 filled it, the newer 3 and 4 saw it empty: gone, left out.
  const std::vector<AggregateVoxel> gone = {Voxel(5, 0, 0, {1, 2})};
  EXPECT_EQ(Keep(gone, {1, 2, 3, 4}, Knows({{3, 5.f}, {4, 5.f}})), (std::vector<char>{0}));
  // One against one: the newer decides.
  EXPECT_EQ(Keep({Voxel(5, 0, 0, {1})}, {1, 2}, Knows({{2, 5.f}})), (std::vector<char>{0}));
  EXPECT_EQ(Keep({Voxel(5, 0, 0, {2})}, {1, 2}, Knows({{1, 5.f}})), (std::vector<char>{1}));
}

TEST(VoxelConsensus, SessionsThatWereElsewhereDoNotCount) {
  // Session 2 filled a voxel 1.5 m away (beyond the 1 m reach) and its octree does not know
  // x = 0: session 1's voxel has nobody against it.
  const std::vector<AggregateVoxel> voxels = {Voxel(0, 0, 0, {1}), Voxel(0, 1.5f, 0, {2})};
  EXPECT_EQ(Keep(voxels, {1, 2}, Knows({})), (std::vector<char>{1, 1}));
  // A session without an octree that filled nothing nearby is not there either.
  EXPECT_EQ(Keep({Voxel(0, 0, 0, {1})}, {1, 2, 3}, Knows({})), (std::vector<char>{1}));
}

}  // namespace
}  // namespace mapdelta::server
