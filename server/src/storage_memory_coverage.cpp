// In-memory coverage store: one map keyed by (tile, session), which orders as the SQL backends
// list (ix, iy, session_id).
#include "storage_memory.hpp"

namespace mapdelta::server {

void MemoryCoverageStore::Put(const std::vector<CoverageRecord>& records) {
  auto lock = Lock();
  for (const CoverageRecord& r : records) {
    t().coverage[std::make_pair(r.tile, r.session_id)] = r;
  }
}

std::vector<CoverageRecord> MemoryCoverageStore::List(const Rect& rect, int64_t since_ms,
                                                      bool with_bits) {
  auto lock = Lock();
  std::vector<CoverageRecord> out;
  for (const auto& [key, row] : t().coverage) {
    if (!InTileRect(key.first, rect) || row.observed_ms < since_ms) continue;
    out.push_back(row);
    if (!with_bits) out.back().bits.clear();
  }
  return out;
}

}  // namespace mapdelta::server
