#include "tile_work.hpp"

#include <atomic>
#include <chrono>
#include <thread>

#include "commit_passes.hpp"
#include "jobs.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/parallel.hpp"
#include "tile_classifier.hpp"

namespace mapdelta::server {
namespace {

// Classifies one claimed item and stages the result; false if the claim was taken over.
bool ClassifyItem(Storage& storage, const ServerConfig& config, const TileWorkItem& item,
                  ObservedCache& cache) {
  const TileGrid grid(config.storage.tile_size_m);
  // Read per item: a reclassify job changes the settings only after the commits before it.
  const ClassifyConfig cc = CurrentClassifyConfig(storage, config.classify);
  TileChangesRecord record = ClassifyTile(storage, grid, item.tile, item.prior_version, cc,
                                          PipelineDetectionParams(config.pipeline), cache)
                                 .record;
  record.updated_ms = NowMs();
  if (storage.jobs().CompleteTileWork(item, record)) return true;
  MD_LOG(kWarn, "job " << item.job_id << ": tile " << item.tile.ToString()
                       << " was taken over by another worker; its result is kept, not this one");
  return false;
}

}  // namespace

int64_t ClassifyClaimedTiles(Storage& storage, const ServerConfig& config,
                             std::optional<int64_t> job_id, const std::function<bool()>& stop,
                             ObservedCache* cache) {
  std::optional<ObservedCache> own_cache;
  if (!cache) cache = &own_cache.emplace(storage);
  // An item takes far less than a lease (one tile's classification); one that outlives it is
  // claimed again by another worker, and the claim count refuses the slower result.
  const int64_t lease_ms = int64_t{config.jobs.lease_s} * 1000;
  std::atomic<int64_t> completed{0};
  RunOnThreads(config.pipeline.threads, [&](int) {
    while (!stop()) {
      const std::optional<TileWorkItem> item =
          storage.jobs().ClaimTileWork(job_id, NowMs(), lease_ms);
      if (!item) return;
      if (!ClassifyItem(storage, config, *item, *cache)) continue;
      ++completed;
      if (storage.tiles().PublishTileWork(item->job_id) == PublishOutcome::kPublished) {
        MD_LOG(kInfo, "job " << item->job_id << ": every tile classified; published by "
                             << storage.jobs().worker_id());
      }
    }
  });
  return completed;
}

std::vector<TileWorkItem> ClassifyCommitTiles(Storage& storage, const ServerConfig& config,
                                              int64_t job_id, int64_t prior_version,
                                              const std::vector<TileId>& tiles,
                                              const std::function<bool()>& stop,
                                              ObservedCache& cache) {
  // Polled: the wait is for items other workers are classifying right now (milliseconds each)
  // or for a lease to run out.
  constexpr auto kPoll = std::chrono::milliseconds(50);
  if (tiles.empty()) return {};
  storage.jobs().AddTileWork(job_id, prior_version, tiles);
  while (true) {
    ClassifyClaimedTiles(storage, config, job_id, stop, &cache);
    if (stop()) throw JobInterrupted(false);
    // Also publishes here if the last item's worker died between completing and publishing.
    if (storage.tiles().PublishTileWork(job_id) != PublishOutcome::kNotReady) {
      return storage.jobs().ListTileWork(job_id);
    }
    std::this_thread::sleep_for(kPoll);
  }
}

}  // namespace mapdelta::server
