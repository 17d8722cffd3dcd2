// The storage contract, part 6: coverage rows (issue #20 item 4, coverage_store.hpp). The bits
// are opaque to the stores: what is checked is the key (tile, session), replacement and removal,
// the order, and the rect and time filters.
#include "storage_contract.hpp"

namespace mapdelta::server::testing {
namespace {

CoverageRecord Row(int32_t ix, int32_t iy, int64_t session, int64_t observed_ms,
                   int64_t observed_points, const std::string& vehicle = "car") {
  CoverageRecord r;
  r.tile = TileId(ix, iy);
  r.session_id = session;
  r.vehicle_id = vehicle;
  r.observed_ms = observed_ms;
  r.prior_row_version = 3;
  r.prior_points = 40;
  r.observed_points = observed_points;
  r.bits = Bytes{static_cast<uint8_t>(session), static_cast<uint8_t>(observed_points), 0, 255};
  return r;
}

const Rect kEverywhere{-1000, -1000, 1000, 1000};

TEST_P(StorageContract, CoverageRowsAreListedByTileThenSessionWithTheirFields) {
  s().coverage().Put({Row(2, 0, 9, 500, 7, "van"), Row(-1, 4, 3, 100, 1), Row(2, 0, 4, 300, 40)});
  s().coverage().Put({Row(-1, 3, 8, 200, 2)});
  const std::vector<CoverageRecord> rows = s().coverage().List(kEverywhere, 0, true);
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_EQ(rows[0].tile, TileId(-1, 3));
  EXPECT_EQ(rows[1].tile, TileId(-1, 4));
  EXPECT_EQ(rows[2].tile, TileId(2, 0));
  EXPECT_EQ(rows[2].session_id, 4);
  EXPECT_EQ(rows[3].session_id, 9);
  const CoverageRecord& r = rows[3];
  EXPECT_EQ(r.vehicle_id, "van");
  EXPECT_EQ(r.observed_ms, 500);
  EXPECT_EQ(r.prior_row_version, 3);
  EXPECT_EQ(r.prior_points, 40);
  EXPECT_EQ(r.observed_points, 7);
  EXPECT_EQ(r.bits, (Bytes{9, 7, 0, 255}));
  // Without bits: the same rows, bits left empty.
  const std::vector<CoverageRecord> bare = s().coverage().List(kEverywhere, 0, false);
  ASSERT_EQ(bare.size(), 4u);
  for (const CoverageRecord& b : bare) EXPECT_TRUE(b.bits.empty());
  EXPECT_EQ(bare[3].observed_points, 7);
}

TEST_P(StorageContract, CoverageListsFilterByTileRectAndObservedTime) {
  s().coverage().Put(
      {Row(0, 0, 1, 100, 5), Row(1, 0, 1, 100, 5), Row(1, 1, 2, 250, 5), Row(5, 1, 3, 900, 5)});
  const auto in_rect = s().coverage().List(Rect{1, 0, 4, 1}, 0, false);
  ASSERT_EQ(in_rect.size(), 2u);
  EXPECT_EQ(in_rect[0].tile, TileId(1, 0));
  EXPECT_EQ(in_rect[1].tile, TileId(1, 1));
  // since_ms is inclusive.
  const auto recent = s().coverage().List(kEverywhere, 250, false);
  ASSERT_EQ(recent.size(), 2u);
  EXPECT_EQ(recent[0].session_id, 2);
  EXPECT_EQ(recent[1].session_id, 3);
  EXPECT_TRUE(s().coverage().List(Rect{6, 0, 9, 9}, 0, true).empty());
}

TEST_P(StorageContract, CoveragePutReplacesTheRowOfItsTileAndSession) {
  s().coverage().Put({Row(0, 0, 1, 100, 5), Row(0, 0, 2, 100, 6)});
  CoverageRecord again = Row(0, 0, 1, 100, 12);
  again.prior_row_version = 4;
  again.prior_points = 50;
  // A row without observed points (a touched tile without prior points) is kept as well.
  CoverageRecord empty = Row(3, 3, 1, 100, 0);
  empty.prior_row_version = 0;
  empty.prior_points = 0;
  empty.bits = Bytes{1};
  s().coverage().Put({again, empty});
  const auto rows = s().coverage().List(kEverywhere, 0, true);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].session_id, 1);
  EXPECT_EQ(rows[0].observed_points, 12);
  EXPECT_EQ(rows[0].prior_row_version, 4);
  EXPECT_EQ(rows[0].prior_points, 50);
  EXPECT_EQ(rows[0].bits, again.bits);
  EXPECT_EQ(rows[1].session_id, 2);
  EXPECT_EQ(rows[1].observed_points, 6);
  EXPECT_EQ(rows[2].tile, TileId(3, 3));
  EXPECT_EQ(rows[2].observed_points, 0);
  EXPECT_EQ(rows[2].prior_row_version, 0);
  EXPECT_EQ(rows[2].bits, Bytes{1});
}

}  // namespace
}  // namespace mapdelta::server::testing
