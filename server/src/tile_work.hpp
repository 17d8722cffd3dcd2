#pragma once
// Per-tile claims within one commit (issue #19): step 5 of a commit job (classify the touched
// tiles and their neighbours) is a set of work items in the job store, one per tile. Any
// worker claims items (the job's own worker, a worker waiting for an earlier job, an idle
// one), classifies the tile and stages the result; the results are published together once
// every item is done, so readers never see half a commit. A worker that dies holding items
// leaves them to the others once their lease ran out; its late results are refused by the
// claim's fencing token. Classification is a pure function of the stored inputs (aggregates,
// session octrees, prior, settings), so who classifies a tile does not change the result.
#include <functional>
#include <optional>
#include <vector>

#include "mapdelta/server/config.hpp"
#include "mapdelta/server/storage.hpp"

namespace mapdelta::server {

class ObservedCache;

// Claims and classifies items (of job_id, or of any running job) on pipeline.threads threads
// until none is claimable or stop() turns true; publishes a job whose last item it finished.
// cache, if given, is used for every item (a job's own octree seeded in it); else one is made
// for this call. Returns how many items this call completed.
int64_t ClassifyClaimedTiles(Storage& storage, const ServerConfig& config,
                             std::optional<int64_t> job_id, const std::function<bool()>& stop,
                             ObservedCache* cache = nullptr);

// The commit job's side: adds the job's items (kept as they are on resume), classifies them
// with the other workers, waits for items others hold (taking over those whose lease ran out)
// and returns the job's items once they are published. Throws JobInterrupted when stop() turns
// true (shutdown, lost job lease); published or not, the items stay for whoever resumes.
std::vector<TileWorkItem> ClassifyCommitTiles(Storage& storage, const ServerConfig& config,
                                              int64_t job_id, int64_t prior_version,
                                              const std::vector<TileId>& tiles,
                                              const std::function<bool()>& stop,
                                              ObservedCache& cache);

}  // namespace mapdelta::server
