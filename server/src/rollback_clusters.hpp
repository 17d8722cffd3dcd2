#pragma once
// What a rollback does to the change clusters (issue #20): the map is the target version's
// content again, so a cluster is "applied" exactly when the refresh that applied it is part of
// that content.
#include <cstdint>

#include "mapdelta/server/storage.hpp"

namespace mapdelta::server {

struct RollbackClusterCounts {
  int64_t unapplied =
      0;  // applied by a refresh the target does not hold: back to their state before
  int64_t reapplied = 0;  // un-applied by an earlier rollback, held by the target again: applied
};

// After rollback job `job_id` made version `made` current as a copy of version `target`.
// Each change is one Transition (cause and job recorded, one feed entry); running it again finds
// nothing left to do, so a resumed job calls it too. applied_version is kept on an un-applied
// cluster: it names the refresh whose content a later rollback may bring back.
RollbackClusterCounts ReconcileClustersWithRollback(Storage& storage, int64_t job_id,
                                                    int64_t target, int64_t made, int64_t now_ms);

}  // namespace mapdelta::server
