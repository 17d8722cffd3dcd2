// SQLite coverage store: table tile_coverage of migration 008.
#include "storage_sqlite.hpp"

namespace mapdelta::server {

void SqliteCoverageStore::Put(const std::vector<CoverageRecord>& records) {
  auto lock = Lock();
  sql::Transaction tx(db());
  sql::Stmt upsert(db(),
                   "INSERT OR REPLACE INTO tile_coverage (tile, ix, iy, session_id, vehicle_id, "
                   "observed_ms, prior_row_version, prior_points, observed_points, bits) "
                   "VALUES (?,?,?,?,?,?,?,?,?,?)");
  for (const CoverageRecord& r : records) {
    upsert.Reset();
    upsert.Bind(1, r.tile.ToString())
        .Bind(2, int64_t{r.tile.ix()})
        .Bind(3, int64_t{r.tile.iy()})
        .Bind(4, r.session_id)
        .Bind(5, r.vehicle_id)
        .Bind(6, r.observed_ms)
        .Bind(7, r.prior_row_version)
        .Bind(8, r.prior_points)
        .Bind(9, r.observed_points)
        .Bind(10, r.bits)
        .Run();
  }
  tx.Commit();
}

std::vector<CoverageRecord> SqliteCoverageStore::List(const Rect& rect, int64_t since_ms,
                                                      bool with_bits) {
  auto lock = Lock();
  sql::Stmt s(db(),
              "SELECT ix, iy, session_id, vehicle_id, observed_ms, prior_row_version, "
              "prior_points, observed_points, CASE WHEN ? = 1 THEN bits ELSE X'' END "
              "FROM tile_coverage WHERE ix BETWEEN ? AND ? AND iy BETWEEN ? AND ? "
              "AND observed_ms >= ? ORDER BY ix, iy, session_id");
  s.Bind(1, int64_t{with_bits ? 1 : 0});
  BindTileRange(s, 2, rect);
  s.Bind(6, since_ms);
  std::vector<CoverageRecord> out;
  while (s.Step()) {
    CoverageRecord r;
    r.tile = TileId(static_cast<int32_t>(s.Int(0)), static_cast<int32_t>(s.Int(1)));
    r.session_id = s.Int(2);
    r.vehicle_id = s.Text(3);
    r.observed_ms = s.Int(4);
    r.prior_row_version = s.Int(5);
    r.prior_points = s.Int(6);
    r.observed_points = s.Int(7);
    r.bits = s.Blob(8);
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace mapdelta::server
