#include "mapdelta/server/metrics.hpp"

#include <sstream>

#ifdef __GLIBC__
#include <malloc.h>
#endif

namespace mapdelta::server {
namespace {

// glibc's heap, summed over its arenas: what the program holds (in_use), what malloc keeps from
// earlier frees without giving it back to the system (free_held: RSS that is no data), and the
// big blocks served by mmap (returned at free). RSS far above in_use is fragmentation or arenas
// kept by threads; in_use growing is data held. mallinfo2 walks the arenas (a scrape's cost).
std::string HeapGauges() {
#ifdef __GLIBC__
  const struct mallinfo2 m = mallinfo2();
  std::ostringstream os;
  os << "# HELP mapdelta_heap_bytes glibc malloc heap: in_use (allocated, incl. mmapped), "
        "free_held (freed, kept in the arenas), mmapped (blocks served by mmap).\n"
     << "# TYPE mapdelta_heap_bytes gauge\n"
     << "mapdelta_heap_bytes{kind=\"in_use\"} " << m.uordblks + m.hblkhd << "\n"
     << "mapdelta_heap_bytes{kind=\"free_held\"} " << m.fordblks << "\n"
     << "mapdelta_heap_bytes{kind=\"mmapped\"} " << m.hblkhd << "\n";
  return os.str();
#else
  return "";
#endif
}

}  // namespace

void Metrics::CountRequest(const std::string& route, int status, double seconds) {
  std::lock_guard lock(mutex_);
  RouteStats& s = requests_[{route, status}];
  s.count += 1;
  s.seconds += seconds;
}

std::string Metrics::Render(const std::vector<std::pair<JobState, int64_t>>& jobs_by_state,
                            const ObservedCacheStats& oc) const {
  std::ostringstream os;
  os << "# HELP mapdelta_http_requests_total HTTP requests by route pattern and status.\n"
     << "# TYPE mapdelta_http_requests_total counter\n";
  {
    std::lock_guard lock(mutex_);
    for (const auto& [key, s] : requests_) {
      os << "mapdelta_http_requests_total{route=\"" << key.first << "\",status=\"" << key.second
         << "\"} " << s.count << "\n";
    }
    os << "# HELP mapdelta_http_request_seconds_total Time spent serving requests.\n"
       << "# TYPE mapdelta_http_request_seconds_total counter\n";
    for (const auto& [key, s] : requests_) {
      os << "mapdelta_http_request_seconds_total{route=\"" << key.first << "\",status=\""
         << key.second << "\"} " << s.seconds << "\n";
    }
  }
  os << "# HELP mapdelta_keyframes_ingested_total Keyframes stored (not counting identical "
        "retries).\n"
     << "# TYPE mapdelta_keyframes_ingested_total counter\n"
     << "mapdelta_keyframes_ingested_total " << keyframes_ingested.load() << "\n"
     << "# HELP mapdelta_keyframe_bytes_total Depth PNG bytes stored.\n"
     << "# TYPE mapdelta_keyframe_bytes_total counter\n"
     << "mapdelta_keyframe_bytes_total " << keyframe_bytes.load() << "\n"
     << "# HELP mapdelta_keyframes_rejected_total Keyframe uploads rejected by validation.\n"
     << "# TYPE mapdelta_keyframes_rejected_total counter\n"
     << "mapdelta_keyframes_rejected_total " << keyframes_rejected.load() << "\n"
     << "# HELP mapdelta_jobs_finished_total Jobs finished by this process.\n"
     << "# TYPE mapdelta_jobs_finished_total counter\n"
     << "mapdelta_jobs_finished_total " << jobs_finished.load() << "\n"
     << "# HELP mapdelta_job_seconds_total Wall time spent in jobs by this process.\n"
     << "# TYPE mapdelta_job_seconds_total counter\n"
     << "mapdelta_job_seconds_total " << job_seconds_ms.load() / 1000.0 << "\n"
     << "# HELP mapdelta_job_tiles_applied_total Tile updates committed by jobs.\n"
     << "# TYPE mapdelta_job_tiles_applied_total counter\n"
     << "mapdelta_job_tiles_applied_total " << job_tiles_applied.load() << "\n"
     << "# HELP mapdelta_observed_cache_requests_total Observed-octree requests by how the "
        "cache answered: hit, miss (merged the octrees), shared (waited for another request's "
        "merge of the same tile state).\n"
     << "# TYPE mapdelta_observed_cache_requests_total counter\n"
     << "mapdelta_observed_cache_requests_total{result=\"hit\"} " << oc.hits << "\n"
     << "mapdelta_observed_cache_requests_total{result=\"miss\"} " << oc.misses << "\n"
     << "mapdelta_observed_cache_requests_total{result=\"shared\"} " << oc.shared << "\n"
     << "# HELP mapdelta_observed_cache_evictions_total Entries dropped for the byte bound.\n"
     << "# TYPE mapdelta_observed_cache_evictions_total counter\n"
     << "mapdelta_observed_cache_evictions_total " << oc.evictions << "\n"
     << "# HELP mapdelta_observed_cache_too_large_total Octrees larger than the whole bound "
        "(served, not kept).\n"
     << "# TYPE mapdelta_observed_cache_too_large_total counter\n"
     << "mapdelta_observed_cache_too_large_total " << oc.too_large << "\n"
     << "# HELP mapdelta_observed_cache_bytes Bytes held by the observed-octree cache.\n"
     << "# TYPE mapdelta_observed_cache_bytes gauge\n"
     << "mapdelta_observed_cache_bytes " << oc.bytes << "\n"
     << "# HELP mapdelta_observed_cache_entries Tiles held by the observed-octree cache.\n"
     << "# TYPE mapdelta_observed_cache_entries gauge\n"
     << "mapdelta_observed_cache_entries " << oc.entries << "\n"
     << "# HELP mapdelta_observed_cache_max_bytes The cache's bound "
        "(http.observed_cache_bytes; 0 = off).\n"
     << "# TYPE mapdelta_observed_cache_max_bytes gauge\n"
     << "mapdelta_observed_cache_max_bytes " << oc.max_bytes << "\n"
     << HeapGauges() << "# HELP mapdelta_jobs Jobs in the database by state.\n"
     << "# TYPE mapdelta_jobs gauge\n";
  for (const auto& [state, name] : EnumNames<JobState>::kValues) {
    int64_t n = 0;
    for (const auto& [s, count] : jobs_by_state) {
      if (s == state) n = count;
    }
    os << "mapdelta_jobs{state=\"" << name << "\"} " << n << "\n";
  }
  return os.str();
}

}  // namespace mapdelta::server
