#include "change_evidence.hpp"

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
  if (!facts) return;  // a session the tile no longer lists: counted, without vehicle or day
  g.vehicles.insert(facts->vehicle_id);
  g.days.insert(UtcDate(facts->created_ms));
}

std::string Plural(size_t n, const char* word) {
  return std::to_string(n) + " " + word + (n == 1 ? "" : "s");
}

}  // namespace

bool SessionGroup::Independent(const LifecycleConfig& c) const {
  const size_t m = static_cast<size_t>(c.confirm_vehicles);
  return sessions.size() >= static_cast<size_t>(c.confirm_sessions) &&
         (vehicles.size() >= m || days.size() >= m);
}

std::string SessionGroup::Describe() const {
  std::string ids;
  for (int64_t s : sessions) ids += (ids.empty() ? "" : ", ") + std::to_string(s);
  return Plural(sessions.size(), "session") + (ids.empty() ? "" : " (" + ids + ")") + " from " +
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
    return nlohmann::json{{"sessions", g.sessions}, {"vehicles", g.vehicles}, {"days", g.days}};
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
  const size_t support = e.supporting.sessions.size();
  const size_t contra = e.contradicting.sessions.size();
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
