#pragma once
// Process-wide counters exported in Prometheus text format at /metrics. Thread-safe.
#include <atomic>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "mapdelta/server/states.hpp"

namespace mapdelta::server {

// The served observed-octree cache (observed_tile_cache.hpp), as /metrics shows it.
struct ObservedCacheStats {
  int64_t hits = 0;       // answered from the cache
  int64_t misses = 0;     // built (the octrees merged), by this request
  int64_t shared = 0;     // waited for another request's build of the same tile state
  int64_t evictions = 0;  // entries dropped for the byte bound
  int64_t too_large = 0;  // built bytes larger than the whole bound: served, not kept
  int64_t bytes = 0, entries = 0, max_bytes = 0;
};

class Metrics {
 public:
  void CountRequest(const std::string& route, int status, double seconds);
  std::atomic<int64_t> keyframes_ingested{0};
  std::atomic<int64_t> keyframe_bytes{0};
  std::atomic<int64_t> keyframes_rejected{0};
  std::atomic<int64_t> jobs_finished{0};
  std::atomic<int64_t> job_tiles_applied{0};
  std::atomic<int64_t> job_seconds_ms{0};
  // Renders everything; extra gauges (job queue by state, the observed-octree cache) are
  // passed in by the caller.
  std::string Render(const std::vector<std::pair<JobState, int64_t>>& jobs_by_state,
                     const ObservedCacheStats& observed_cache = {}) const;

 private:
  struct RouteStats {
    int64_t count = 0;
    double seconds = 0;
  };
  mutable std::mutex mutex_;
  std::map<std::pair<std::string, int>, RouteStats> requests_;
};

}  // namespace mapdelta::server
