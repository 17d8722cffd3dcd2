#pragma once
// Versioned, checksummed, zlib-compressed binary encodings of what the server stores: per tile
// prior points, the aggregated voxel cloud with per-voxel session support and classified
// changes with their evidence, a change cluster's voxel keys; per session the observed octree;
// per (tile, session) the prior points observed.
// Layout: magic "MDB1", kind (u8), format version (u16), raw size (u64), CRC-32 of the raw payload
// (u32), then the zlib stream.
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "mapdelta/common/point_cloud.hpp"
#include "mapdelta/server/storage.hpp"
#include "point_bits.hpp"

namespace mapdelta::server {

// One voxel of a tile's aggregated cloud (voxel edge = aggregation voxel size).
struct AggregateVoxel {
  Point centroid = Point::Zero();
  uint32_t point_count = 0;  // points averaged into the centroid, over all sessions
  // The most keyframes of one session with a point here (ChangeDetectionResult::global_support);
  // 0 = unknown (aggregated before it was kept): then the voxel masks removals as before.
  uint32_t keyframes = 0;
  std::vector<int64_t> sessions;  // sessions that put a point here (sorted, unique)
};
using VoxelKey = std::array<int32_t, 3>;
using TileAggregate = std::map<VoxelKey, AggregateVoxel>;

enum class ChangeKind : uint8_t { kNew = 0, kRemoved = 1 };

struct ChangePoint {
  Point position = Point::Zero();
  ChangeKind kind = ChangeKind::kNew;
  float confidence = 0;
  std::vector<int64_t> observed_by;   // sessions whose observed area covers the point
  std::vector<int64_t> supported_by;  // sessions whose own data agree with the change
};

Bytes EncodePoints(const PointCloud& cloud);
PointCloud DecodePoints(const Bytes& blob);  // throws Error(kParse / kUnsupported)
Bytes EncodeAggregate(const TileAggregate& aggregate);
TileAggregate DecodeAggregate(const Bytes& blob);
Bytes EncodeChanges(const std::vector<ChangePoint>& changes);
std::vector<ChangePoint> DecodeChanges(const Bytes& blob);
// A change cluster's voxel keys (sorted; change_lifecycle.cpp).
Bytes EncodeVoxelKeys(const std::vector<VoxelKey>& keys);
std::vector<VoxelKey> DecodeVoxelKeys(const Bytes& blob);
// A session's observed octree: OctoMap's .ot stream with every voxel's log-odds
// (ObservedArea::SerializeEvidence; the per-session free-space evidence of tile_classifier.hpp
// needs it), or the .bt stream (free/occupied only) of databases written before.
Bytes EncodeObserved(const std::string& octree_binary);
// Databases written before octrees went through the codec hold the bare OctoMap stream: that is
// read as it is (recognised by OctoMap's own first line); any other blob without the mapdelta
// header is an error.
std::string DecodeObserved(const Bytes& blob);
// Which prior points of a tile a session observed (coverage.hpp).
Bytes EncodePointBits(const PointBits& bits);
PointBits DecodePointBits(const Bytes& blob);

}  // namespace mapdelta::server
