// PostgreSQL coverage store: table tile_coverage of migrations/postgres/008. A row is written by
// one (tile, session) key, so concurrent writers of the same key are ordered by its row lock
// (ON CONFLICT DO UPDATE); the last one wins, as on SQLite.
#include "storage_postgres.hpp"

namespace mapdelta::server {

void PostgresCoverageStore::Put(const std::vector<CoverageRecord>& records) {
  auto c = Connect();
  pg::Transaction tx(*c);
  for (const CoverageRecord& r : records) {
    c->Query(
        "INSERT INTO tile_coverage (tile, ix, iy, session_id, vehicle_id, observed_ms, "
        "prior_row_version, prior_points, observed_points, bits) "
        "VALUES ($1,$2,$3,$4,$5,$6,$7,$8,$9,$10) ON CONFLICT (tile, session_id) DO UPDATE SET "
        "vehicle_id = EXCLUDED.vehicle_id, observed_ms = EXCLUDED.observed_ms, "
        "prior_row_version = EXCLUDED.prior_row_version, prior_points = EXCLUDED.prior_points, "
        "observed_points = EXCLUDED.observed_points, bits = EXCLUDED.bits",
        pg::Params()
            .Add(r.tile.ToString())
            .Add(int64_t{r.tile.ix()})
            .Add(int64_t{r.tile.iy()})
            .Add(r.session_id)
            .Add(r.vehicle_id)
            .Add(r.observed_ms)
            .Add(r.prior_row_version)
            .Add(r.prior_points)
            .Add(r.observed_points)
            .Add(r.bits));
  }
  tx.Commit();
}

std::vector<CoverageRecord> PostgresCoverageStore::List(const Rect& rect, int64_t since_ms,
                                                        bool with_bits) {
  auto c = Connect();
  pg::Params p;
  p.Add(int64_t{with_bits ? 1 : 0});
  pg_rows::AddTileRange(p, rect).Add(since_ms);
  const pg::Result r = c->Query(
      "SELECT ix, iy, session_id, vehicle_id, observed_ms, prior_row_version, prior_points, "
      "observed_points, CASE WHEN $1 = 1 THEN bits ELSE ''::bytea END FROM tile_coverage "
      "WHERE ix BETWEEN $2 AND $3 AND iy BETWEEN $4 AND $5 AND observed_ms >= $6 "
      "ORDER BY ix, iy, session_id",
      p);
  std::vector<CoverageRecord> out;
  for (int i = 0; i < r.rows(); ++i) {
    CoverageRecord row;
    row.tile = TileId(static_cast<int32_t>(r.Int(i, 0)), static_cast<int32_t>(r.Int(i, 1)));
    row.session_id = r.Int(i, 2);
    row.vehicle_id = r.Text(i, 3);
    row.observed_ms = r.Int(i, 4);
    row.prior_row_version = r.Int(i, 5);
    row.prior_points = r.Int(i, 6);
    row.observed_points = r.Int(i, 7);
    row.bits = r.Bytes(i, 8);
    out.push_back(std::move(row));
  }
  return out;
}

}  // namespace mapdelta::server
