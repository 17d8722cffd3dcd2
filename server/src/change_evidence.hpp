#pragma once
// A change cluster's evidence (change_lifecycle.hpp has the rules): which sessions support or
// contradict it, from how many vehicles and UTC days; stored as the cluster's evidence_json.
#include <nlohmann/json.hpp>

#include <optional>
#include <set>
#include <string>
#include <vector>

#include "change_clusters.hpp"
#include "localization_quality.hpp"
#include "mapdelta/server/change_cluster_store.hpp"
#include "mapdelta/server/config.hpp"

namespace mapdelta::server {

struct SessionGroup {
  std::vector<int64_t> sessions;
  double weight = 0;  // the sessions' localization weights, summed (localization_quality.hpp)
  std::set<std::string> vehicles;  // of the sessions with weight >= kCredibleWeight only
  std::set<std::string> days;      // UTC dates (YYYY-MM-DD) of those sessions
  // A weight of at least k, from at least m vehicles or on at least m days.
  bool Independent(const LifecycleConfig& c) const;
  std::string Describe() const;  // "2 sessions (3, 4) from 2 vehicles on 1 day"
};

struct ClusterEvidence {
  SessionGroup supporting, contradicting;
};

ClusterEvidence EvidenceOf(const ExtractedCluster& cluster,
                           const std::vector<SessionFacts>& sessions);
nlohmann::json ToJson(const ClusterEvidence& e);
// The supporting sessions stored in an evidence_json (empty if unreadable).
std::vector<int64_t> SupportingSessions(const std::string& evidence_json);

// The automatic transition the evidence calls for from `state`, with its cause, or nullopt.
struct StateChange {
  ClusterState to;
  std::string cause;
};
std::optional<StateChange> EvidenceTransition(ClusterState state, const ClusterEvidence& e,
                                              const LifecycleConfig& config);

}  // namespace mapdelta::server
