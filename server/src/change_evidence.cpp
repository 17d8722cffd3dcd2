#include "change_evidence.hpp"

#include <cmath>
#include <cstdio>
#include <ctime>
#include <map>

namespace mapdelta::server {
namespace {

std::string UtcDate(int64_t ms) {
  const std::time_t seconds = static_cast<std::time_t>(ms / 1000);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char text[16];
  std::strftime(text, sizeof text, "%Y-%m-%d", &tm);
  return text;
}

void Add(SessionGroup& g, int64_t session, const SessionFacts* facts) {
  g.sessions.push_back(session);
  g.weight += facts ? facts->weight : 1.0;
  // A session the tile no longer lists counts without vehicle or day; a poorly localized one
  // cannot make the evidence independent.
  if (!facts || facts->weight < kCredibleWeight) return;
  g.vehicles.insert(facts->vehicle_id);
  g.days.insert(UtcDate(facts->created_ms));
}

std::string Plural(size_t n, const char* word) {
  return std::to_string(n) + " " + word + (n == 1 ? "" : "s");
}

}  // namespace

bool SessionGroup::Independent(const LifecycleConfig& c) const {
  const size_t m = static_cast<size_t>(c.confirm_vehicles);
  constexpr double kRounding = 1e-9;  // weights are sums of decimals
  return weight + kRounding >= c.confirm_sessions && (vehicles.size() >= m || days.size() >= m);
}

std::string SessionGroup::Describe() const {
  std::string ids;
  for (int64_t s : sessions) ids += (ids.empty() ? "" : ", ") + std::to_string(s);
  char w[32] = "";
  if (std::abs(weight - static_cast<double>(sessions.size())) > 1e-9)
    std::snprintf(w, sizeof w, "; weight %.2f", weight);
  return Plural(sessions.size(), "session") + (ids.empty() ? "" : " (" + ids + w + ")") + " from " +
         Plural(vehicles.size(), "vehicle") + " on " + Plural(days.size(), "day");
}

ClusterEvidence EvidenceOf(const ExtractedCluster& cluster,
                           const std::vector<SessionFacts>& sessions) {
  std::map<int64_t, const SessionFacts*> facts;
  for (const SessionFacts& f : sessions) facts[f.id] = &f;
  ClusterEvidence e;
  for (const auto& [session, counts] : cluster.by_session) {
    auto it = facts.find(session);
    const SessionFacts* f = it == facts.end() ? nullptr : it->second;
    if (counts.supported > 0 && 2 * counts.supported >= counts.observed) {
      Add(e.supporting, session, f);
    } else if (counts.observed > 0) {
      Add(e.contradicting, session, f);
    }
  }
  return e;
}

nlohmann::json ToJson(const ClusterEvidence& e) {
  const auto group = [](const SessionGroup& g) {
    return nlohmann::json{
        {"sessions", g.sessions}, {"weight", g.weight}, {"vehicles", g.vehicles}, {"days", g.days}};
  };
  return nlohmann::json{{"supporting", group(e.supporting)},
                        {"contradicting", group(e.contradicting)}};
}

std::vector<int64_t> SupportingSessions(const std::string& evidence_json) {
  const nlohmann::json j = nlohmann::json::parse(evidence_json, nullptr, false);
  if (j.is_discarded() || !j.contains("supporting")) return {};
  return j["supporting"].value("sessions", std::vector<int64_t>{});
}

std::optional<StateChange> EvidenceTransition(ClusterState state, const ClusterEvidence& e,
                                              const LifecycleConfig& config) {
  const double support = e.supporting.weight, contra = e.contradicting.weight;
  const bool contradicted = e.contradicting.Independent(config) && contra > support;
  const std::string balance = "; supported by " + e.supporting.Describe();
  if (state == ClusterState::kCandidate && contradicted) {
    return StateChange{ClusterState::kRejected,
                       "contradicted by " + e.contradicting.Describe() + balance};
  }
  if (state == ClusterState::kCandidate && e.supporting.Independent(config) && support > contra) {
    return StateChange{ClusterState::kConfirmed, "supported by " + e.supporting.Describe() +
                                                     "; contradicted by " +
                                                     e.contradicting.Describe()};
  }
  if (state == ClusterState::kConfirmed && contradicted) {
    return StateChange{ClusterState::kExpired,
                       "later sessions observe the place agreeing with "
                       "the prior: contradicted by " +
                           e.contradicting.Describe() + balance};
  }
  return std::nullopt;
}

}  // namespace mapdelta::server
