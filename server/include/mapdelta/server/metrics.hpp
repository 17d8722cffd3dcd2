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

class Metrics {
 public:
  void CountRequest(const std::string& route, int status, double seconds);
  std::atomic<int64_t> keyframes_ingested{0};
  std::atomic<int64_t> keyframe_bytes{0};
  std::atomic<int64_t> keyframes_rejected{0};
  std::atomic<int64_t> jobs_finished{0};
  std::atomic<int64_t> job_tiles_applied{0};
  std::atomic<int64_t> job_seconds_ms{0};
  // Renders everything; extra gauges (job queue by state) are passed in by the caller.
  std::string Render(const std::vector<std::pair<JobState, int64_t>>& jobs_by_state) const;

 private:
  struct RouteStats {
    int64_t count = 0;
    double seconds = 0;
  };
  mutable std::mutex mutex_;
  std::map<std::pair<std::string, int>, RouteStats> requests_;
};

}  // namespace mapdelta::server
