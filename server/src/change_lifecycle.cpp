#include "change_lifecycle.hpp"

#include <algorithm>
#include <set>
#include <tuple>

#include "blob_codec.hpp"
#include "change_clusters.hpp"
#include "change_evidence.hpp"

namespace mapdelta::server {
namespace {

bool Matchable(ClusterState s) {
  return s == ClusterState::kCandidate || s == ClusterState::kConfirmed ||
         s == ClusterState::kRejected;
}

std::string JobText(const TilePublication& p) {
  return p.job_id > 0 ? "job " + std::to_string(p.job_id) : "a classification";
}

// The session whose commit is the publishing job (nullopt for other jobs).
std::optional<int64_t> CausingSession(const TilePublication& p) {
  for (const SessionFacts& s : p.sessions) {
    if (p.job_id > 0 && s.job_id == p.job_id) return s.id;
  }
  return std::nullopt;
}

ClusterTransitionRecord Transition(const TilePublication& p, std::optional<ClusterState> from,
                                   ClusterState to, std::string cause) {
  ClusterTransitionRecord t;
  t.from = from;
  t.to = to;
  t.at_ms = p.now_ms;
  t.cause = std::move(cause);
  if (p.job_id > 0) t.job_id = p.job_id;
  t.session_id = CausingSession(p);
  t.actor = "job";
  return t;
}

// Moves the update's cluster to `to`, recording why.
void Move(ClusterUpdate& u, const TilePublication& p, ClusterState to, std::string cause) {
  u.transitions.push_back(Transition(p, u.cluster.state, to, std::move(cause)));
  u.cluster.state = to;
}

// A cluster record with the extracted geometry and evidence.
void FillFromExtracted(ChangeClusterRecord& r, const ExtractedCluster& c, const ClusterEvidence& e,
                       const TilePublication& p) {
  r.tile = p.tile;
  r.kind = c.kind;
  r.point_count = c.point_count;
  r.min = c.min;
  r.max = c.max;
  r.centroid = c.centroid;
  r.voxels = EncodeVoxelKeys(c.voxels);
  r.evidence_json = ToJson(e).dump();
  r.prior_version = p.classified->prior_version;
  r.updated_ms = p.now_ms;
}

struct Match {
  int64_t overlap;
  size_t extracted, existing;
};

// Greedy one-to-one matching, largest overlap first (ties: lower indices), same kind only.
std::vector<Match> MatchClusters(const std::vector<ExtractedCluster>& extracted,
                                 const std::vector<ChangeClusterRecord>& active,
                                 const std::vector<std::vector<VoxelKey>>& active_keys,
                                 std::vector<bool>* overlapped) {
  std::vector<Match> pairs;
  for (size_t i = 0; i < extracted.size(); ++i) {
    for (size_t j = 0; j < active.size(); ++j) {
      if (active[j].kind != extracted[i].kind || !Matchable(active[j].state)) continue;
      const int64_t n = OverlapCount(extracted[i].voxels, active_keys[j]);
      if (n > 0) pairs.push_back({n, i, j});
      if (n > 0) (*overlapped)[j] = true;
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Match& a, const Match& b) {
    return std::tie(b.overlap, a.extracted, a.existing) <
           std::tie(a.overlap, b.extracted, b.existing);
  });
  std::vector<bool> used_e(extracted.size()), used_a(active.size());
  std::vector<Match> out;
  for (const Match& m : pairs) {
    if (used_e[m.extracted] || used_a[m.existing]) continue;
    used_e[m.extracted] = used_a[m.existing] = true;
    out.push_back(m);
  }
  return out;
}

// An existing candidate / confirmed cluster the classification no longer shows.
std::optional<ClusterUpdate> Vanished(const ChangeClusterRecord& r, bool overlapped,
                                      const TilePublication& p) {
  if (r.state != ClusterState::kCandidate && r.state != ClusterState::kConfirmed) {
    return std::nullopt;
  }
  ClusterUpdate u{r, {}};
  u.cluster.updated_ms = p.now_ms;
  if (overlapped) {
    Move(u, p, ClusterState::kRejected,
         JobText(p) + ": merged into an overlapping cluster of the same kind");
    return u;
  }
  std::set<int64_t> tile_sessions;
  for (const SessionFacts& s : p.sessions) tile_sessions.insert(s.id);
  bool evidence_kept = false;
  for (int64_t s : SupportingSessions(r.evidence_json)) evidence_kept |= tile_sessions.count(s) > 0;
  if (!evidence_kept) return std::nullopt;  // its evidence was reset: nothing observed it since
  if (r.state == ClusterState::kCandidate) {
    Move(u, p, ClusterState::kRejected,
         JobText(p) + " no longer detects it: the tile's sessions do not show the change");
  } else {
    Move(u, p, ClusterState::kExpired,
         JobText(p) +
             " no longer detects it: later sessions observe the place agreeing with "
             "the prior");
  }
  return u;
}

// An applied cluster that the opposite kind of change now overlaps.
std::optional<ClusterUpdate> Reverted(const ChangeClusterRecord& r,
                                      const std::vector<VoxelKey>& keys,
                                      const std::vector<ExtractedCluster>& extracted,
                                      const TilePublication& p) {
  if (r.state != ClusterState::kApplied || p.classified->prior_version < r.applied_version) {
    return std::nullopt;
  }
  for (const ExtractedCluster& c : extracted) {
    if (c.kind == r.kind || OverlapCount(c.voxels, keys) == 0) continue;
    ClusterUpdate u{r, {}};
    u.cluster.updated_ms = p.now_ms;
    Move(u, p, ClusterState::kExpired,
         JobText(p) + " finds the opposite change here against prior version " +
             std::to_string(p.classified->prior_version) +
             ": the place agrees with the prior before the refresh again");
    return u;
  }
  return std::nullopt;
}

}  // namespace

std::vector<ClusterUpdate> ChangeLifecycle::Plan(
    const TilePublication& publication, const std::vector<ChangeClusterRecord>& active) const {
  if (publication.refreshed) return PlanRefreshed(publication, active);
  if (publication.classified) return PlanClassified(publication, active);
  return {};
}

std::vector<ClusterUpdate> ChangeLifecycle::PlanClassified(
    const TilePublication& p, const std::vector<ChangeClusterRecord>& active) const {
  const std::vector<ExtractedCluster> extracted = ExtractClusters(
      DecodeChanges(p.classified->changes), config_.cluster_link_m, config_.cluster_voxel_m);
  std::vector<std::vector<VoxelKey>> keys;
  for (const ChangeClusterRecord& r : active) keys.push_back(DecodeVoxelKeys(r.voxels));
  std::vector<bool> overlapped(active.size());
  const std::vector<Match> matches = MatchClusters(extracted, active, keys, &overlapped);

  std::vector<ClusterUpdate> out;
  std::vector<std::optional<size_t>> match_of(extracted.size());
  std::vector<bool> matched(active.size());
  for (const Match& m : matches) {
    match_of[m.extracted] = m.existing;
    matched[m.existing] = true;
  }
  for (size_t i = 0; i < extracted.size(); ++i) {
    const ClusterEvidence evidence = EvidenceOf(extracted[i], p.sessions);
    ClusterUpdate u;
    if (match_of[i]) {
      u.cluster = active[*match_of[i]];
    } else {
      u.cluster.created_ms = p.now_ms;
      u.transitions.push_back(Transition(
          p, std::nullopt, ClusterState::kCandidate,
          "detected by " + JobText(p) + "; supported by " + evidence.supporting.Describe()));
    }
    FillFromExtracted(u.cluster, extracted[i], evidence, p);
    if (auto change = EvidenceTransition(u.cluster.state, evidence, config_)) {
      Move(u, p, change->to, JobText(p) + ": " + change->cause);
    }
    out.push_back(std::move(u));
  }
  for (size_t j = 0; j < active.size(); ++j) {
    if (matched[j]) continue;
    std::optional<ClusterUpdate> u = active[j].state == ClusterState::kApplied
                                         ? Reverted(active[j], keys[j], extracted, p)
                                         : Vanished(active[j], overlapped[j], p);
    if (u) out.push_back(std::move(*u));
  }
  return out;
}

std::vector<ClusterUpdate> ChangeLifecycle::PlanRefreshed(
    const TilePublication& p, const std::vector<ChangeClusterRecord>& active) const {
  std::set<VoxelKey> occupied;
  for (const Point& q : DecodePoints(p.refreshed->points)) {
    occupied.insert(VoxelOf(q, config_.cluster_voxel_m));
  }
  std::vector<ClusterUpdate> out;
  for (const ChangeClusterRecord& r : active) {
    if (!Matchable(r.state)) continue;
    const std::vector<VoxelKey> keys = DecodeVoxelKeys(r.voxels);
    size_t agree = 0;
    for (const VoxelKey& k : keys)
      agree += (occupied.count(k) > 0) == (r.kind == ClusterKind::kNew);
    if (keys.empty() || 2 * agree < keys.size()) continue;
    ClusterUpdate u{r, {}};
    u.cluster.applied_version = p.refreshed_version;
    u.cluster.updated_ms = p.now_ms;
    const char* note = r.state == ClusterState::kCandidate  ? " (it was not confirmed)"
                       : r.state == ClusterState::kRejected ? " (although it was rejected)"
                                                            : "";
    Move(u, p, ClusterState::kApplied,
         "merged by refresh job " + std::to_string(p.job_id) + " into prior version " +
             std::to_string(p.refreshed_version) + note);
    out.push_back(std::move(u));
  }
  return out;
}

}  // namespace mapdelta::server
