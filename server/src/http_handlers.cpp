// HTTP routes: each handler parses the request, checks the role, calls MapService and writes
// the response. Errors become {"error": {"code", "message"}} via the one error table.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string_view>
#include <vector>

#include "api_json.hpp"
#include "auth.hpp"
#include "http_common.hpp"
#include "http_routes.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/map_service.hpp"

#include <httplib.h>  // last: its <resolv.h> defines macros that break Eigen

namespace mapdelta::server {

std::string_view OpenApiYaml();  // embedded openapi.yaml

namespace {

using Req = httplib::Request;
using Res = httplib::Response;

void WriteJson(Res& res, int status, const Json& body) {
  res.status = status;
  res.set_content(body.dump(), "application/json");
  if (body.is_object() && body.contains("prior_version")) {
    res.set_header("X-Prior-Version", std::to_string(body["prior_version"].get<int64_t>()));
  }
}

using QueryNames = std::vector<std::string_view>;

// Query parameters a route does not take are refused like unknown body fields, so that a typo
// or a filter that does not exist (`since=`) is not silently ignored; a repeated one too (which
// value would count?). Only the URL's own parameters: httplib also files a form-encoded body
// under req.params, and such a body on a JSON route is a 415, not an unknown parameter.
// Checked before the token, like the path itself (an unknown route is a 404 for anyone).
void CheckQueryNames(const Req& req, const QueryNames& allowed) {
  const size_t question = req.target.find('?');
  if (question == std::string::npos) return;
  httplib::Params given;
  httplib::detail::parse_query_text(req.target.substr(question + 1), given);  // as req.params
  for (auto it = given.begin(); it != given.end(); it = given.upper_bound(it->first)) {
    if (std::find(allowed.begin(), allowed.end(), it->first) == allowed.end()) {
      std::string takes;
      for (std::string_view name : allowed)
        takes += (takes.empty() ? "" : ", ") + std::string(name);
      throw ApiError(ApiCode::kInvalidArgument, "unknown query parameter '" + it->first +
                                                    "' (this route takes " +
                                                    (takes.empty() ? "none" : takes) + ")");
    }
    if (given.count(it->first) > 1) {
      throw ApiError(ApiCode::kInvalidArgument,
                     "query parameter '" + it->first + "' is given more than once");
    }
  }
}

// Wraps one handler: request id, query names, timing, error mapping, one structured log line,
// metrics.
template <typename Fn>
httplib::Server::Handler Wrap(MapService& service, std::string route, QueryNames query, Fn fn) {
  return [&service, route = std::move(route), query = std::move(query), fn](const Req& req,
                                                                            Res& res) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string request_id = RequestId(req);
    res.set_header("X-Request-Id", request_id);
    std::string role = "-";
    try {
      if (service.stopping() && req.method != "GET")
        throw ApiError(ApiCode::kShuttingDown, "server is shutting down");
      CheckQueryNames(req, query);
      fn(req, res, role);
      if (res.status == -1) res.status = 200;
    } catch (const ApiError& e) {
      WriteError(res, e.code(), e.what(), request_id);
    } catch (const Json::exception& e) {
      WriteError(res, ApiCode::kInvalidJson, std::string("malformed JSON: ") + e.what(),
                 request_id);
    } catch (const Error& e) {
      const ApiCode code = e.code() == ErrorCode::kInvalidArgument || e.code() == ErrorCode::kParse
                               ? ApiCode::kInvalidArgument
                           : e.code() == ErrorCode::kNotFound ? ApiCode::kNotFound
                                                              : ApiCode::kInternal;
      WriteError(res, code, e.what(), request_id);
    } catch (const std::exception& e) {
      MD_LOG(kError, "request_id=" << request_id << " internal error: " << e.what());
      WriteError(res, ApiCode::kInternal,
                 "internal error (see server log, request " + request_id + ")", request_id);
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    service.metrics().CountRequest(route, res.status, seconds);
    MD_LOG(kInfo, "request_id=" << request_id << " method=" << req.method << " route=" << route
                                << " path=" << req.path << " status=" << res.status
                                << " role=" << role << " ms=" << std::lround(seconds * 1000)
                                << " bytes_in=" << req.body.size()
                                << " bytes_out=" << res.body.size());
  };
}

Role Auth(MapService& s, const Req& req, std::string& role, std::initializer_list<Role> allowed) {
  const TokenRecord t = s.Authorize(req.get_header_value("Authorization"), allowed);
  role = std::string(ToString(t.role)) + ":" + t.id;
  return t.role;
}

Json ParseJsonBody(const Req& req, int64_t limit) {
  if (static_cast<int64_t>(req.body.size()) > limit) {
    throw ApiError(ApiCode::kPayloadTooLarge, "body of " + std::to_string(req.body.size()) +
                                                  " bytes exceeds the limit of " +
                                                  std::to_string(limit));
  }
  const std::string type = req.get_header_value("Content-Type");
  if (type.rfind("application/json", 0) != 0) {
    throw ApiError(ApiCode::kUnsupportedMedia, "Content-Type must be application/json");
  }
  return ParseApiJson(req.body, "body");
}

int64_t PathInt(const Req& req, int index) {
  const std::string text = req.matches[index];
  return std::stoll(text);  // the route regex allows 1..18 digits only
}

std::optional<std::string> Query(const Req& req, const char* name) {
  if (!req.has_param(name)) return std::nullopt;
  return req.get_param_value(name);
}

double QueryDouble(const Req& req, const char* name, std::optional<double> fallback) {
  auto v = Query(req, name);
  if (!v) {
    if (fallback) return *fallback;
    throw ApiError(ApiCode::kInvalidArgument,
                   std::string("query parameter '") + name + "' is required");
  }
  char* end = nullptr;
  const double d = std::strtod(v->c_str(), &end);
  if (v->empty() || *end != '\0' || !std::isfinite(d)) {
    throw ApiError(ApiCode::kInvalidArgument,
                   std::string("query parameter '") + name + "': not a finite number");
  }
  return d;
}

int64_t QueryInt(const Req& req, const char* name, int64_t fallback) {
  auto v = Query(req, name);
  if (!v) return fallback;
  char* end = nullptr;
  errno = 0;
  const long long n = std::strtoll(v->c_str(), &end, 10);
  if (v->empty() || *end != '\0' || errno == ERANGE) {
    throw ApiError(ApiCode::kInvalidArgument,
                   std::string("query parameter '") + name + "': not an integer");
  }
  return n;
}

std::optional<int64_t> QueryVersion(const Req& req) {
  if (!req.has_param("version")) return std::nullopt;
  return QueryInt(req, "version", 0);
}

// If-None-Match naming this ETag (or "*"): the client has the bytes already.
bool ClientHas(const Req& req, const std::string& etag) {
  const std::string given = req.get_header_value("If-None-Match");
  if (given.empty() || etag.empty()) return false;
  if (given == "*") return true;
  std::stringstream list(given);
  std::string item;
  while (std::getline(list, item, ',')) {
    const size_t a = item.find_first_not_of(' '), b = item.find_last_not_of(' ');
    if (a == std::string::npos) continue;
    std::string tag = item.substr(a, b - a + 1);
    if (tag.rfind("W/", 0) == 0) tag = tag.substr(2);  // weak comparison (RFC 9110 13.1.2)
    if (tag == etag) return true;
  }
  return false;
}

// ETag, Cache-Control and 304 for a response whose bytes `etag` names.
bool AnswerNotModified(const Req& req, Res& res, const std::string& etag, bool immutable) {
  if (etag.empty()) return false;
  res.set_header("ETag", etag);
  // Immutable: a year without asking again; else revalidate every time (cheap: 304).
  res.set_header("Cache-Control", immutable ? "public, max-age=31536000, immutable" : "no-cache");
  if (!ClientHas(req, etag)) return false;
  res.status = 304;
  return true;
}

void WriteFile(const Req& req, Res& res, const FilePayload& p) {
  res.set_header("X-Prior-Version", std::to_string(p.prior_version));
  if (AnswerNotModified(req, res, p.etag, p.immutable)) return;
  res.status = 200;
  res.set_content(std::string(p.bytes.begin(), p.bytes.end()), p.content_type);
}

// JSON whose ETag is a hash of its text (FNV-1a, 64 bit): a poller that has the answer gets 304.
void WriteJsonRevalidated(const Req& req, Res& res, const Json& body) {
  const std::string text = body.dump();
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  char etag[24];
  std::snprintf(etag, sizeof etag, "\"%016llx\"", static_cast<unsigned long long>(h));
  if (AnswerNotModified(req, res, etag, false)) return;
  res.status = 200;
  res.set_content(text, "application/json");
}

constexpr auto V = Role::kVehicle;
constexpr auto R = Role::kReader;
constexpr auto A = Role::kAdmin;

void RegisterPublicRoutes(httplib::Server& s, MapService& svc) {
  s.Get("/health", Wrap(svc, "/health", {}, [&svc](const Req&, Res& res, std::string&) {
          WriteJson(res, 200, svc.Health());
        }));
  s.Get("/metrics", Wrap(svc, "/metrics", {}, [&svc](const Req&, Res& res, std::string&) {
          res.set_content(svc.RenderMetrics(), "text/plain; version=0.0.4");
        }));
  s.Get("/v1/openapi.yaml",
        Wrap(svc, "/v1/openapi.yaml", {}, [](const Req&, Res& res, std::string&) {
          res.set_content(std::string(OpenApiYaml()), "application/yaml");
        }));
}

void RegisterVehicleRoutes(httplib::Server& s, MapService& svc) {
  const int64_t json_limit = svc.config().http.max_body_bytes;
  const int64_t keyframe_limit = svc.config().http.max_keyframe_bytes;
  s.Post("/v1/sessions", Wrap(svc, "/v1/sessions", {},
                              [&svc, json_limit](const Req& req, Res& res, std::string& role) {
                                Auth(svc, req, role, {V});
                                WriteJson(res, 201,
                                          svc.CreateSession(ParseJsonBody(req, json_limit)));
                              }));
  s.Put(R"(/v1/sessions/([0-9]{1,18})/keyframes/([0-9]{1,18}))",
        Wrap(svc, "/v1/sessions/{id}/keyframes/{seq}", {},
             [&svc, keyframe_limit](const Req& req, Res& res, std::string& role) {
               Auth(svc, req, role, {V});
               if (static_cast<int64_t>(req.body.size()) > keyframe_limit) {
                 throw ApiError(
                     ApiCode::kPayloadTooLarge,
                     "keyframe upload exceeds " + std::to_string(keyframe_limit) + " bytes");
               }
               if (!req.is_multipart_form_data()) {
                 throw ApiError(
                     ApiCode::kUnsupportedMedia,
                     "Content-Type must be multipart/form-data with parts 'meta' and 'depth'");
               }
               if (!req.has_file("meta") || !req.has_file("depth")) {
                 throw ApiError(
                     ApiCode::kInvalidArgument,
                     "multipart body needs parts 'meta' (JSON) and 'depth' (16-bit PNG)");
               }
               const Json meta = ParseApiJson(req.get_file_value("meta").content, "part 'meta'");
               const std::string& png = req.get_file_value("depth").content;
               bool created = false;
               const Json out = svc.PutKeyframe(PathInt(req, 1), PathInt(req, 2), meta,
                                                Bytes(png.begin(), png.end()), &created);
               WriteJson(res, created ? 201 : 200, out);
             }));
  s.Post(R"(/v1/sessions/([0-9]{1,18})/commit)",
         Wrap(svc, "/v1/sessions/{id}/commit", {},
              [&svc](const Req& req, Res& res, std::string& role) {
                Auth(svc, req, role, {V});
                WriteJson(res, 202, svc.CommitSession(PathInt(req, 1)));
              }));
  s.Get(R"(/v1/sessions/([0-9]{1,18}))",
        Wrap(svc, "/v1/sessions/{id}", {}, [&svc](const Req& req, Res& res, std::string& role) {
          Auth(svc, req, role, {V, R});
          WriteJson(res, 200, svc.GetSession(PathInt(req, 1)));
        }));
}

void RegisterMapRoutes(httplib::Server& s, MapService& svc) {
  // --- prior map
  s.Get("/v1/prior/tiles",
        Wrap(svc, "/v1/prior/tiles", {"x", "y", "radius", "version"},
             [&svc](const Req& req, Res& res, std::string& role) {
               Auth(svc, req, role, {V, R});
               WriteJson(
                   res, 200,
                   svc.ListPriorTilesNear(QueryDouble(req, "x", std::nullopt),
                                          QueryDouble(req, "y", std::nullopt),
                                          QueryDouble(req, "radius", 100.0), QueryVersion(req)));
             }));
  s.Get("/v1/map", Wrap(svc, "/v1/map", {}, [&svc](const Req& req, Res& res, std::string& role) {
          Auth(svc, req, role, {R, V, A});
          WriteJson(res, 200, svc.GetMap());
        }));
  s.Get("/v1/prior/versions",
        Wrap(svc, "/v1/prior/versions", {}, [&svc](const Req& req, Res& res, std::string& role) {
          Auth(svc, req, role, {V, R});
          WriteJson(res, 200, svc.ListPriorVersions());
        }));
  s.Get(R"(/v1/prior/tiles/([-0-9_]{3,24}))",
        Wrap(svc, "/v1/prior/tiles/{tile}", {"version", "format"},
             [&svc](const Req& req, Res& res, std::string& role) {
               Auth(svc, req, role, {V, R});
               WriteFile(req, res,
                         svc.GetPriorTile(req.matches[1], QueryVersion(req),
                                          Query(req, "format").value_or("pcd")));
             }));

  // --- changes
  s.Get(
      "/v1/changes/tiles",
      Wrap(svc, "/v1/changes/tiles", {"bbox", "min_confidence", "min_support", "page", "page_size"},
           [&svc](const Req& req, Res& res, std::string& role) {
             Auth(svc, req, role, {R});
             const auto bbox = Query(req, "bbox");
             if (!bbox)
               throw ApiError(ApiCode::kInvalidArgument, "query parameter 'bbox' is required");
             WriteJson(res, 200,
                       svc.ListChangedTiles(
                           *bbox, QueryDouble(req, "min_confidence", 0.0), QueryInt(req, "page", 1),
                           QueryInt(req, "page_size", 100), QueryInt(req, "min_support", 0)));
           }));
  s.Get(R"(/v1/changes/tiles/([-0-9_]{3,24}))",
        Wrap(svc, "/v1/changes/tiles/{tile}",
             {"format", "kind", "min_confidence", "min_support", "state"},
             [&svc](const Req& req, Res& res, std::string& role) {
               Auth(svc, req, role, {R});
               WriteFile(req, res,
                         svc.GetTileChanges(req.matches[1], Query(req, "format").value_or("json"),
                                            Query(req, "kind").value_or(""),
                                            QueryDouble(req, "min_confidence", 0.0),
                                            QueryInt(req, "min_support", 0), Query(req, "state")));
             }));
  s.Get(R"(/v1/observed/tiles/([-0-9_]{3,24})\.bt)",
        Wrap(svc, "/v1/observed/tiles/{tile}.bt", {},
             [&svc](const Req& req, Res& res, std::string& role) {
               Auth(svc, req, role, {R});
               // A reader that has this tile state's octree gets 304 without a merge.
               WriteFile(req, res,
                         svc.GetObservedTile(req.matches[1], [&req](const std::string& e) {
                           return ClientHas(req, e);
                         }));
             }));
}

// Change clusters (issue #20): the feed, listings, one cluster, and the admin's decisions.
void RegisterClusterRoutes(httplib::Server& s, MapService& svc) {
  const int64_t json_limit = svc.config().http.max_body_bytes;
  s.Get("/v1/changes/feed", Wrap(svc, "/v1/changes/feed", {"since", "limit"},
                                 [&svc](const Req& req, Res& res, std::string& role) {
                                   Auth(svc, req, role, {R, A});
                                   WriteJsonRevalidated(
                                       req, res,
                                       svc.ChangeFeed(Query(req, "since"), Query(req, "limit")));
                                 }));
  s.Get("/v1/changes/clusters",
        Wrap(svc, "/v1/changes/clusters", {"bbox", "state", "page", "page_size"},
             [&svc](const Req& req, Res& res, std::string& role) {
               Auth(svc, req, role, {R, A});
               WriteJsonRevalidated(
                   req, res,
                   svc.ListClusters(Query(req, "bbox"), Query(req, "state"),
                                    QueryInt(req, "page", 1), QueryInt(req, "page_size", 100)));
             }));
  s.Get(R"(/v1/changes/clusters/([0-9]{1,18}))",
        Wrap(svc, "/v1/changes/clusters/{id}", {},
             [&svc](const Req& req, Res& res, std::string& role) {
               Auth(svc, req, role, {R, A});
               WriteJsonRevalidated(req, res, svc.GetCluster(PathInt(req, 1)));
             }));
  for (const auto& [verb, state] : {std::pair{"confirm", ClusterState::kConfirmed},
                                    std::pair{"reject", ClusterState::kRejected}}) {
    const std::string route = std::string("/v1/admin/changes/{id}/") + verb;
    s.Post(std::string(R"(/v1/admin/changes/([0-9]{1,18})/)") + verb,
           Wrap(svc, route, {},
                [&svc, json_limit, to = state](const Req& req, Res& res, std::string& role) {
                  const TokenRecord t = svc.Authorize(req.get_header_value("Authorization"), {A});
                  role = std::string(ToString(t.role)) + ":" + t.id;
                  WriteJson(res, 200,
                            svc.DecideCluster(PathInt(req, 1), to, ParseJsonBody(req, json_limit),
                                              t.name));
                }));
  }
}

// Coverage and freshness (issue #20 item 4): per prior tile, its points observed lately.
void RegisterCoverageRoutes(httplib::Server& s, MapService& svc) {
  constexpr int64_t kDefaultDays = 30;
  s.Get("/v1/coverage/tiles",
        Wrap(svc, "/v1/coverage/tiles", {"bbox", "days", "page", "page_size"},
             [&svc](const Req& req, Res& res, std::string& role) {
               Auth(svc, req, role, {R, A});
               const auto bbox = Query(req, "bbox");
               if (!bbox)
                 throw ApiError(ApiCode::kInvalidArgument, "query parameter 'bbox' is required");
               WriteJson(res, 200,
                         svc.ListCoverageTiles(*bbox, QueryInt(req, "days", kDefaultDays),
                                               QueryInt(req, "page", 1),
                                               QueryInt(req, "page_size", 100)));
             }));
  s.Get(R"(/v1/coverage/tiles/([-0-9_]{3,24}))",
        Wrap(svc, "/v1/coverage/tiles/{tile}", {"days"},
             [&svc](const Req& req, Res& res, std::string& role) {
               Auth(svc, req, role, {R, A});
               WriteJson(res, 200,
                         svc.GetTileCoverage(req.matches[1], QueryInt(req, "days", kDefaultDays)));
             }));
}

void RegisterAdminRoutes(httplib::Server& s, MapService& svc) {
  const int64_t json_limit = svc.config().http.max_body_bytes;
  const int64_t prior_limit = svc.config().http.max_prior_bytes;
  s.Post("/v1/admin/prior",
         Wrap(svc, "/v1/admin/prior", {"format", "note", "origin", "crs"},
              [&svc, prior_limit](const Req& req, Res& res, std::string& role) {
                Auth(svc, req, role, {A});
                if (static_cast<int64_t>(req.body.size()) > prior_limit) {
                  throw ApiError(ApiCode::kPayloadTooLarge,
                                 "prior upload exceeds " + std::to_string(prior_limit) + " bytes");
                }
                if (req.get_header_value("Content-Type") != "application/octet-stream") {
                  throw ApiError(ApiCode::kUnsupportedMedia,
                                 "Content-Type must be application/octet-stream");
                }
                const auto format = Query(req, "format");
                if (!format)
                  throw ApiError(ApiCode::kInvalidArgument,
                                 "query parameter 'format' (pcd or ply) is required");
                FrameRequest frame;
                frame.crs = Query(req, "crs");
                if (const auto origin = Query(req, "origin")) {
                  frame.origin = ParseOrigin(*origin);
                  if (!frame.origin)
                    throw ApiError(ApiCode::kInvalidArgument,
                                   "query parameter 'origin': expected X,Y,Z in metres");
                }
                WriteJson(res, 201,
                          svc.ImportPrior(Bytes(req.body.begin(), req.body.end()), *format,
                                          Query(req, "note").value_or(""), frame));
              }));
  s.Post("/v1/admin/jobs", Wrap(svc, "/v1/admin/jobs", {},
                                [&svc, json_limit](const Req& req, Res& res, std::string& role) {
                                  Auth(svc, req, role, {A});
                                  WriteJson(res, 202,
                                            svc.CreateJob(ParseJsonBody(req, json_limit)));
                                }));
  s.Get("/v1/admin/jobs",
        Wrap(svc, "/v1/admin/jobs", {"page", "page_size"},
             [&svc](const Req& req, Res& res, std::string& role) {
               Auth(svc, req, role, {A});
               WriteJson(res, 200,
                         svc.ListJobs(QueryInt(req, "page", 1), QueryInt(req, "page_size", 50)));
             }));
  s.Get(R"(/v1/admin/jobs/([0-9]{1,18}))",
        Wrap(svc, "/v1/admin/jobs/{id}", {}, [&svc](const Req& req, Res& res, std::string& role) {
          Auth(svc, req, role, {A});
          WriteJson(res, 200, svc.GetJob(PathInt(req, 1)));
        }));
  s.Post(R"(/v1/admin/jobs/([0-9]{1,18})/cancel)",
         Wrap(svc, "/v1/admin/jobs/{id}/cancel", {},
              [&svc](const Req& req, Res& res, std::string& role) {
                Auth(svc, req, role, {A});
                WriteJson(res, 200, svc.CancelJob(PathInt(req, 1)));
              }));
}

}  // namespace

void RegisterRoutes(httplib::Server& s, MapService& svc) {
  RegisterPublicRoutes(s, svc);
  RegisterVehicleRoutes(s, svc);
  RegisterMapRoutes(s, svc);
  RegisterClusterRoutes(s, svc);
  RegisterCoverageRoutes(s, svc);
  RegisterAdminRoutes(s, svc);
}

}  // namespace mapdelta::server
