#pragma once
// Per-endpoint latencies and answers of a load run, shared by all driver threads. Routes are
// named by their template ("PUT keyframe"), not by path, so percentiles pool like requests.
#include <algorithm>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace mapdelta::bench {

struct RouteStats {
  std::vector<double> latencies_ms;  // answered requests only
  int64_t ok = 0;                    // 2xx
  int64_t client_errors = 0;         // 4xx
  int64_t server_errors = 0;         // 5xx
  int64_t transport_errors = 0;      // no answer (refused, reset, timeout)
};

class LatencyBook {
 public:
  // status 0 = no answer.
  void Record(const std::string& route, int status, double ms) {
    std::lock_guard<std::mutex> lock(mutex_);
    RouteStats& s = routes_[route];
    if (status == 0) {
      ++s.transport_errors;
      return;
    }
    s.latencies_ms.push_back(ms);
    if (status >= 500)
      ++s.server_errors;
    else if (status >= 400)
      ++s.client_errors;
    else
      ++s.ok;
  }
  std::map<std::string, RouteStats> Snapshot() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return routes_;
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::string, RouteStats> routes_;
};

// Nearest-rank percentile (q in [0, 1]) of unsorted values; 0 for none.
inline double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const size_t rank = static_cast<size_t>(q * static_cast<double>(values.size() - 1) + 0.5);
  return values[std::min(rank, values.size() - 1)];
}

}  // namespace mapdelta::bench
