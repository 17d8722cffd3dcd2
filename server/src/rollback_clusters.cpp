#include "rollback_clusters.hpp"

#include <map>
#include <set>
#include <string>
#include <vector>

#include "api_json.hpp"
#include "mapdelta/common/error.hpp"

namespace mapdelta::server {
namespace {

// The refresh (and import) versions whose changes make up `version`'s points: a refresh holds
// its parent's content plus its own merge; a rollback holds exactly its target's content.
std::set<int64_t> ContentVersions(Storage& storage, int64_t version) {
  std::map<int64_t, PriorVersionRecord> by_version;
  for (PriorVersionRecord& v : storage.priors().ListVersions()) by_version[v.version] = v;
  std::set<int64_t> content, visited;
  for (int64_t v = version; v > 0 && visited.insert(v).second;) {
    const auto it = by_version.find(v);
    if (it == by_version.end()) break;
    const PriorVersionRecord& record = it->second;
    if (record.source != PriorSource::kRollback) {
      content.insert(v);
      v = record.parent.value_or(0);
      continue;
    }
    const std::optional<JobRecord> job =
        record.job_id ? storage.jobs().Get(*record.job_id) : std::nullopt;
    if (!job) {
      throw Error(ErrorCode::kInternal, "prior version " + std::to_string(v) +
                                            " is a rollback without its job: cannot tell what "
                                            "it is a copy of");
    }
    v = Json::parse(job->params_json).at("version").get<int64_t>();
  }
  return content;
}

std::vector<ChangeClusterRecord> ClustersIn(ChangeClusterStore& clusters, ClusterState state) {
  constexpr int64_t kPage = 500;
  std::vector<ChangeClusterRecord> all;
  int64_t total = 0;
  for (int64_t offset = 0;; offset += kPage) {
    std::vector<ChangeClusterRecord> page =
        clusters.List(std::nullopt, state, kPage, offset, &total);
    all.insert(all.end(), page.begin(), page.end());
    if (static_cast<int64_t>(page.size()) < kPage) return all;
  }
}

// The cluster's latest transition into `applied`, if any.
std::optional<ClusterTransitionRecord> LastApplied(ChangeClusterStore& clusters, int64_t id) {
  std::optional<ClusterTransitionRecord> last;
  for (const ClusterTransitionRecord& t : clusters.History(id)) {
    if (t.to == ClusterState::kApplied) last = t;
  }
  return last;
}

// Whether the cluster's latest transition is a rollback taking it out of `applied`.
bool UnappliedByRollback(Storage& storage, int64_t id) {
  const std::vector<ClusterTransitionRecord> history = storage.clusters().History(id);
  if (history.empty() || history.back().from != ClusterState::kApplied || !history.back().job_id) {
    return false;
  }
  const std::optional<JobRecord> job = storage.jobs().Get(*history.back().job_id);
  return job && job->type == JobType::kRollback;
}

}  // namespace

RollbackClusterCounts ReconcileClustersWithRollback(Storage& storage, int64_t job_id,
                                                    int64_t target, int64_t made, int64_t now_ms) {
  const std::set<int64_t> content = ContentVersions(storage, target);
  ChangeClusterStore& clusters = storage.clusters();
  const std::string job_text = "rollback job " + std::to_string(job_id) + " made version " +
                               std::to_string(made) + " (a copy of version " +
                               std::to_string(target) + ") current";
  ClusterTransitionRecord t;
  t.at_ms = now_ms;
  t.job_id = job_id;
  t.actor = "job";
  RollbackClusterCounts counts;
  for (const ChangeClusterRecord& c : ClustersIn(clusters, ClusterState::kApplied)) {
    if (!c.applied_version || content.count(*c.applied_version)) continue;
    const std::optional<ClusterTransitionRecord> applied = LastApplied(clusters, c.id);
    t.to = applied && applied->from ? *applied->from : ClusterState::kConfirmed;
    t.cause = job_text + ", which does not hold refresh version " +
              std::to_string(*c.applied_version) + "'s merge of this change";
    if (clusters.Transition(c.id, {ClusterState::kApplied}, t)) ++counts.unapplied;
  }
  t.to = ClusterState::kApplied;
  for (ClusterState state :
       {ClusterState::kCandidate, ClusterState::kConfirmed, ClusterState::kRejected}) {
    for (const ChangeClusterRecord& c : ClustersIn(clusters, state)) {
      if (!c.applied_version || !content.count(*c.applied_version) ||
          !UnappliedByRollback(storage, c.id)) {
        continue;
      }
      t.cause = job_text + ", which holds refresh version " + std::to_string(*c.applied_version) +
                "'s merge of this change again";
      if (clusters.Transition(c.id, {state}, t)) ++counts.reapplied;
    }
  }
  return counts;
}

}  // namespace mapdelta::server
