// MapService: change clusters, their feed and the admin's decisions (issue #20). Clusters are
// written by the publishing stores through ChangeLifecycle (installed in MapService's
// constructor); this file only reads them and records hand decisions.
#include "api_json.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/server/map_service.hpp"
#include "query_params.hpp"

namespace mapdelta::server {
namespace {

constexpr int64_t kMaxFeedLimit = 1000;
constexpr int64_t kDefaultFeedLimit = 100;
constexpr size_t kMaxCauseLength = 500;

// A non-negative decimal integer of at most 18 digits, or an error naming the parameter.
int64_t ParseCount(const std::string& text, const char* name) {
  if (text.empty() || text.size() > 18 ||
      text.find_first_not_of("0123456789") != std::string::npos) {
    throw ApiError(ApiCode::kInvalidArgument, std::string("query parameter '") + name + "': '" +
                                                  text + "' is not a non-negative integer");
  }
  return std::stoll(text);
}

Json Point3(const MapFrame& frame, const std::array<double, 3>& local) {
  return {local[0] + frame.origin.x(), local[1] + frame.origin.y(), local[2] + frame.origin.z()};
}

Json ClusterToJson(const ChangeClusterRecord& c, const MapFrame& frame) {
  Json evidence = Json::parse(c.evidence_json, nullptr, false);
  if (evidence.is_discarded()) evidence = Json::object();
  Json lo = Point3(frame, c.min), hi = Point3(frame, c.max);
  return Json{{"cluster_id", c.id},
              {"tile", c.tile.ToString()},
              {"kind", ToString(c.kind)},
              {"state", ToString(c.state)},
              {"seq", c.seq},
              {"point_count", c.point_count},
              {"bbox", {lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]}},
              {"centroid", Point3(frame, c.centroid)},
              {"prior_version", c.prior_version},
              {"applied_version", c.applied_version ? Json(*c.applied_version) : Json()},
              {"evidence", evidence},
              {"created_at", IsoTime(c.created_ms)},
              {"updated_at", IsoTime(c.updated_ms)}};
}

Json TransitionToJson(const ClusterTransitionRecord& t) {
  return Json{{"seq", t.seq},
              {"from", t.from ? Json(ToString(*t.from)) : Json()},
              {"to", ToString(t.to)},
              {"at", IsoTime(t.at_ms)},
              {"cause", t.cause},
              {"job_id", t.job_id ? Json(*t.job_id) : Json()},
              {"session_id", t.session_id ? Json(*t.session_id) : Json()},
              {"actor", t.actor}};
}

}  // namespace

Json MapService::ChangeFeed(const std::optional<std::string>& since_text,
                            const std::optional<std::string>& limit_text) {
  const int64_t since = since_text ? ParseCount(*since_text, "since") : 0;
  const int64_t limit = limit_text ? ParseCount(*limit_text, "limit") : kDefaultFeedLimit;
  if (limit < 1 || limit > kMaxFeedLimit) {
    throw ApiError(ApiCode::kInvalidArgument, "query parameter 'limit': must be in [1, " +
                                                  std::to_string(kMaxFeedLimit) + "]");
  }
  // Read before the page: a change committed in between is in the next page, never skipped.
  const int64_t last = storage_->clusters().LastSeq();
  if (since > last) {
    throw ApiError(ApiCode::kInvalidArgument, "query parameter 'since': " + std::to_string(since) +
                                                  " is beyond the feed's last position " +
                                                  std::to_string(last) +
                                                  " (a cursor of another database?)");
  }
  const std::vector<ChangeClusterRecord> page = storage_->clusters().Feed(since, limit);
  const MapFrame frame = Frame();
  Json clusters = Json::array();
  int64_t next = since;
  for (const ChangeClusterRecord& c : page) {
    clusters.push_back(ClusterToJson(c, frame));
    next = c.seq;
  }
  const bool more =
      static_cast<int64_t>(page.size()) == limit && next < storage_->clusters().LastSeq();
  return Json{{"since", since}, {"next", next}, {"more", more}, {"clusters", clusters}};
}

Json MapService::ListClusters(const std::optional<std::string>& bbox,
                              const std::optional<std::string>& state_text, int64_t page,
                              int64_t page_size) {
  CheckPage(page, page_size);
  std::optional<ClusterState> state;
  if (const auto states = ParseClusterStates(state_text, /*single=*/true)) state = *states->begin();
  const MapFrame frame = Frame();
  std::optional<Rect> range;
  if (bbox) {
    const std::vector<double> b = ParseBbox(*bbox);
    range = TileRange(TileGrid(config_.storage.tile_size_m), frame, b[0], b[1], b[2], b[3]);
  }
  int64_t total = 0;
  Json clusters = Json::array();
  for (const ChangeClusterRecord& c :
       storage_->clusters().List(range, state, page_size, (page - 1) * page_size, &total)) {
    clusters.push_back(ClusterToJson(c, frame));
  }
  return Json{{"page", page}, {"page_size", page_size}, {"total", total}, {"clusters", clusters}};
}

Json MapService::GetCluster(int64_t cluster_id) {
  const std::optional<ChangeClusterRecord> c = storage_->clusters().Get(cluster_id);
  if (!c) {
    throw ApiError(ApiCode::kNotFound,
                   "change cluster " + std::to_string(cluster_id) + " does not exist");
  }
  Json out = ClusterToJson(*c, Frame());
  Json history = Json::array();
  for (const ClusterTransitionRecord& t : storage_->clusters().History(cluster_id)) {
    history.push_back(TransitionToJson(t));
  }
  out["transitions"] = history;
  return out;
}

Json MapService::DecideCluster(int64_t cluster_id, ClusterState to, const Json& body,
                               const std::string& admin_name) {
  if (!body.is_object()) throw ApiError(ApiCode::kInvalidArgument, "body: expected an object");
  RejectUnknownFields(body, {"cause"}, "body");
  const std::string cause = StringField(body, "cause");
  if (cause.empty() || cause.size() > kMaxCauseLength) {
    throw ApiError(ApiCode::kInvalidArgument, "field 'cause': must be 1 to " +
                                                  std::to_string(kMaxCauseLength) + " characters");
  }
  const std::vector<ClusterState> from =
      to == ClusterState::kConfirmed
          ? std::vector<ClusterState>{ClusterState::kCandidate, ClusterState::kRejected}
          : std::vector<ClusterState>{ClusterState::kCandidate, ClusterState::kConfirmed};
  ClusterTransitionRecord t;
  t.to = to;
  t.at_ms = NowMs();
  t.cause = cause;
  t.actor = "admin:" + admin_name;
  try {
    if (!storage_->clusters().Transition(cluster_id, from, t)) {
      throw ApiError(ApiCode::kNotFound,
                     "change cluster " + std::to_string(cluster_id) + " does not exist");
    }
  } catch (const Error& e) {
    if (e.code() != ErrorCode::kConflict) throw;
    throw ApiError(ApiCode::kClusterState, e.what());
  }
  return GetCluster(cluster_id);
}

}  // namespace mapdelta::server
