// MapService: coverage and freshness queries (coverage.hpp). A tile's numbers are over its
// points at the latest prior version; rows of sessions older than the window count only for
// last_observed.
#include <algorithm>

#include "api_json.hpp"
#include "coverage.hpp"
#include "mapdelta/server/map_service.hpp"
#include "query_params.hpp"

namespace mapdelta::server {
namespace {

constexpr int64_t kDayMs = 86'400'000;
constexpr int64_t kMaxDays = 3650;

// Start of the window: sessions created at or after it count.
int64_t WindowStart(int64_t days) {
  if (days < 1 || days > kMaxDays) {
    throw ApiError(ApiCode::kInvalidArgument,
                   "days must be in [1, " + std::to_string(kMaxDays) + "]");
  }
  return NowMs() - days * kDayMs;
}

Json CoverageToJson(const TileCoverage& c, const TileGrid& grid, const MapFrame& frame) {
  return Json{
      {"tile", c.tile.ToString()},
      {"bounds", UserBounds(grid, frame, c.tile)},
      {"prior_points", c.prior_points},
      {"observed_points", c.observed_points},
      {"fraction", c.fraction()},
      {"last_observed", c.last_observed_ms ? Json(IsoTime(*c.last_observed_ms)) : Json(nullptr)},
      {"sessions", c.sessions.size()},
      {"vehicles", c.vehicles.size()}};
}

// The rows of one tile among rows ordered by tile.
std::vector<CoverageRecord> RowsOf(const std::vector<CoverageRecord>& rows, const TileId& tile) {
  const auto by_tile = [](const CoverageRecord& r, const TileId& t) { return r.tile < t; };
  auto first = std::lower_bound(rows.begin(), rows.end(), tile, by_tile);
  auto last = first;
  while (last != rows.end() && last->tile == tile) ++last;
  return {first, last};
}

}  // namespace

Json MapService::ListCoverageTiles(const std::string& bbox, int64_t days, int64_t page,
                                   int64_t page_size) {
  const std::vector<double> b = ParseBbox(bbox);
  CheckPage(page, page_size);
  const int64_t since_ms = WindowStart(days);
  const int64_t version = RequirePriorVersion();
  const TileGrid grid(config_.storage.tile_size_m);
  const MapFrame frame = Frame();
  const Rect range = TileRange(grid, frame, b[0], b[1], b[2], b[3]);
  const std::vector<PriorTileRecord> prior = storage_->priors().ListTiles(range, version);
  const int64_t total = static_cast<int64_t>(prior.size());
  const int64_t first = std::min(total, (page - 1) * page_size);
  const int64_t end = std::min(total, first + page_size);
  Json tiles = Json::array();
  if (first < end) {
    // The page's tiles are consecutive in (ix, iy): their rows lie in this narrower range.
    const Rect rows_range{double(prior[first].tile.ix()), range.min_y,
                          double(prior[end - 1].tile.ix()), range.max_y};
    const std::vector<CoverageRecord> all = storage_->coverage().List(rows_range, 0, false);
    const std::vector<CoverageRecord> window =
        storage_->coverage().List(rows_range, since_ms, true);
    for (int64_t i = first; i < end; ++i) {
      const TileId& t = prior[i].tile;
      tiles.push_back(
          CoverageToJson(SummarizeTile(prior[i], RowsOf(all, t), RowsOf(window, t)), grid, frame));
    }
  }
  return Json{{"prior_version", version},
              {"days", days},
              {"since", IsoTime(since_ms)},
              {"page", page},
              {"page_size", page_size},
              {"total", total},
              {"tiles", tiles}};
}

Json MapService::GetTileCoverage(const std::string& tile_text, int64_t days) {
  const TileId tile = ParseTile(tile_text);
  const int64_t since_ms = WindowStart(days);
  const int64_t version = RequirePriorVersion();
  const std::optional<PriorTileRecord> prior = storage_->priors().GetTile(tile, version);
  if (!prior || prior->point_count == 0) {
    throw ApiError(ApiCode::kNotFound, "tile " + tile_text + " has no prior points at version " +
                                           std::to_string(version));
  }
  const Rect one{double(tile.ix()), double(tile.iy()), double(tile.ix()), double(tile.iy())};
  const std::vector<CoverageRecord> all = storage_->coverage().List(one, 0, false);
  const std::vector<CoverageRecord> window = storage_->coverage().List(one, since_ms, true);
  const TileCoverage c = SummarizeTile(*prior, all, window);
  const TileGrid grid(config_.storage.tile_size_m);
  Json out = CoverageToJson(c, grid, Frame());
  Json observations = Json::array();
  for (const CoverageRecord& r : window) {
    if (!c.sessions.count(r.session_id)) continue;  // a row of an older prior row
    observations.push_back({{"session_id", r.session_id},
                            {"vehicle_id", r.vehicle_id},
                            {"observed_at", IsoTime(r.observed_ms)},
                            {"observed_points", r.observed_points}});
  }
  out["observations"] = observations;
  out["prior_version"] = version;
  out["days"] = days;
  out["since"] = IsoTime(since_ms);
  return out;
}

}  // namespace mapdelta::server
