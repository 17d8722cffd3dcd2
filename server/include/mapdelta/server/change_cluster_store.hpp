#pragma once
// Change clusters (issue #20): connected changed voxels of one kind in a tile, each with a
// lifecycle state (states.hpp: candidate -> confirmed -> applied -> expired, or rejected), every
// state change recorded as a transition with its time, cause and the job / session behind it,
// and a feed of those changes in one monotonic sequence (seq) kept by the database.
//
// Who writes what: clusters change only inside the writes that publish tile changes
// (TileStore::ApplyChanges, PublishTileWork, ApplyRefresh), in the same transaction, through the
// ClusterLifecycle the service installs on the tile store: readers never see the clusters of a
// half-published commit. An admin's confirm / reject is ChangeClusterStore::Transition. Every
// transition takes the next seq under one lock (a counter row), so seq order is commit order,
// also with several processes on PostgreSQL: a feed reader never skips a change that commits
// later with a smaller number.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "mapdelta/common/tiling.hpp"
#include "mapdelta/server/states.hpp"
#include "mapdelta/server/storage_types.hpp"

namespace mapdelta::server {

struct TileChangesRecord;
struct RefreshTileWrite;

struct ChangeClusterRecord {
  int64_t id = 0;  // assigned by the store when created
  TileId tile;
  ClusterKind kind = ClusterKind::kNew;
  ClusterState state = ClusterState::kCandidate;
  int64_t point_count = 0;
  std::array<double, 3> min{}, max{}, centroid{};  // the map's local frame, metres
  Bytes voxels;               // opaque here: the cluster's voxel keys (for matching across commits)
  std::string evidence_json;  // opaque here: supporting / contradicting sessions, vehicles, days
  int64_t prior_version = 0;  // the prior version it was last classified against
  std::optional<int64_t> applied_version;  // the version of the refresh that applied it (kept
                                           // when a rollback un-applies it)
  int64_t created_ms = 0, updated_ms = 0;
  int64_t seq = 0;  // feed position of its latest state change (assigned by the store)
};

struct ClusterTransitionRecord {
  int64_t seq = 0;  // assigned by the store
  int64_t cluster_id = 0;
  std::optional<ClusterState> from;  // nullopt: the cluster was created
  ClusterState to = ClusterState::kCandidate;
  int64_t at_ms = 0;
  std::string cause;
  std::optional<int64_t> job_id, session_id;
  std::string actor;  // "job" for a job's publish, "admin:<token name>" for a hand decision
};

// What the lifecycle knows of a session (to count independent evidence).
struct SessionFacts {
  int64_t id = 0;
  std::string vehicle_id;
  int64_t created_ms = 0;
  std::optional<int64_t> job_id;  // its commit job
  double weight = 1.0;            // its localization weight (1 until its commit sets one)
};

// One tile being published: either a new classification or a refresh that merged the tile into
// prior version refreshed_version (refreshed = the tile's points there).
struct TilePublication {
  TileId tile;
  int64_t job_id = 0;  // the publishing job (0: none)
  int64_t now_ms = 0;
  const TileChangesRecord* classified = nullptr;
  const RefreshTileWrite* refreshed = nullptr;
  int64_t refreshed_version = 0;
  std::vector<SessionFacts> sessions;  // the tile's aggregated sessions (before a refresh)
};

struct ClusterUpdate {
  ChangeClusterRecord cluster;  // id 0: a new cluster
  std::vector<ClusterTransitionRecord>
      transitions;  // in order; seq and cluster_id set by the store
};

// The service's rules (change_lifecycle.hpp). Runs inside the publishing transaction: it must
// not call the storage. active = the tile's clusters that are not expired, ordered by id.
class ClusterLifecycle {
 public:
  virtual ~ClusterLifecycle() = default;
  virtual std::vector<ClusterUpdate> Plan(const TilePublication& publication,
                                          const std::vector<ChangeClusterRecord>& active) const = 0;
};

class ChangeClusterStore {
 public:
  virtual ~ChangeClusterStore() = default;
  virtual std::optional<ChangeClusterRecord> Get(int64_t id) = 0;
  // The cluster's transitions in seq order (empty for an unknown id).
  virtual std::vector<ClusterTransitionRecord> History(int64_t id) = 0;
  // Clusters whose latest state change has seq > since, in seq order, at most limit.
  virtual std::vector<ChangeClusterRecord> Feed(int64_t since, int64_t limit) = 0;
  // The greatest seq handed out (0 if none).
  virtual int64_t LastSeq() = 0;
  // Clusters in the rect of tile indices (all if nullopt) and state (any if nullopt), ordered by
  // id; *total = how many match before paging.
  virtual std::vector<ChangeClusterRecord> List(const std::optional<Rect>& rect,
                                                std::optional<ClusterState> state, int64_t limit,
                                                int64_t offset, int64_t* total) = 0;
  // One transaction: if the cluster's state is one of `from`, moves it to transition.to under the
  // next seq and records the transition (its cluster_id and from are filled in); returns the
  // updated cluster. nullopt for an unknown id; Error(kConflict), nothing written, if its state
  // is not in `from`.
  virtual std::optional<ChangeClusterRecord> Transition(int64_t id,
                                                        const std::vector<ClusterState>& from,
                                                        ClusterTransitionRecord transition) = 0;
};

}  // namespace mapdelta::server
