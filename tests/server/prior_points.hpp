#pragma once
// A prior version's points as a sorted multiset, for tests that compare versions (rollback,
// Autoware round trip) point for point.
#include <array>
#include <cstdint>
#include <limits>
#include <set>

#include "blob_codec.hpp"
#include "mapdelta/common/point_cloud.hpp"
#include "mapdelta/server/map_service.hpp"

namespace mapdelta::testing {

using PointSet = std::multiset<std::array<float, 3>>;

inline PointSet ToSet(const PointCloud& cloud) {
  PointSet set;
  for (const Point& p : cloud) set.insert({p.x(), p.y(), p.z()});
  return set;
}

// Every point of prior version `version`, read back from the service's store.
inline PointSet PriorPoints(server::MapService& service, int64_t version) {
  constexpr double kLow = std::numeric_limits<int32_t>::min();
  constexpr double kHigh = std::numeric_limits<int32_t>::max();
  PointSet set;
  auto& priors = service.storage().priors();
  for (const auto& t : priors.ListTiles(server::Rect{kLow, kLow, kHigh, kHigh}, version)) {
    for (const Point& p : server::DecodePoints(priors.GetTile(t.tile, version)->points)) {
      set.insert({p.x(), p.y(), p.z()});
    }
  }
  return set;
}

}  // namespace mapdelta::testing
