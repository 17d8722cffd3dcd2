// HTTP routes: each handler parses the request, checks the role, calls MapService and writes
// the response. Errors become {"error": {"code", "message"}} via the one error table.
#include <atomic>
#include <chrono>
#include <cmath>

#include "api_json.hpp"
#include "auth.hpp"
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

void WriteError(Res& res, ApiCode code, const std::string& message, const std::string& request_id) {
  const ApiErrorInfo& info = Info(code);
  res.status = info.http_status;
  Json body{{"error", {{"code", info.name}, {"message", message}, {"request_id", request_id}}}};
  res.set_content(body.dump(), "application/json");
}

void WriteJson(Res& res, int status, const Json& body) {
  res.status = status;
  res.set_content(body.dump(), "application/json");
  if (body.is_object() && body.contains("prior_version")) {
    res.set_header("X-Prior-Version", std::to_string(body["prior_version"].get<int64_t>()));
  }
}

std::string RequestId(const Req& req) {
  std::string id = req.get_header_value("X-Request-Id");
  const bool ok = !id.empty() && id.size() <= 64 &&
                  std::all_of(id.begin(), id.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_'; });
  return ok ? id : RandomHex(8);
}

// Wraps one handler: request id, timing, error mapping, one structured log line, metrics.
template <typename Fn>
httplib::Server::Handler Wrap(MapService& service, std::string route, Fn fn) {
  return [&service, route = std::move(route), fn](const Req& req, Res& res) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string request_id = RequestId(req);
    res.set_header("X-Request-Id", request_id);
    std::string role = "-";
    try {
      if (service.stopping() && req.method != "GET") throw ApiError(ApiCode::kShuttingDown, "server is shutting down");
      fn(req, res, role);
      if (res.status == -1) res.status = 200;
    } catch (const ApiError& e) {
      WriteError(res, e.code(), e.what(), request_id);
    } catch (const Json::exception& e) {
      WriteError(res, ApiCode::kInvalidJson, std::string("malformed JSON: ") + e.what(), request_id);
    } catch (const Error& e) {
      const ApiCode code = e.code() == ErrorCode::kInvalidArgument || e.code() == ErrorCode::kParse
                               ? ApiCode::kInvalidArgument
                               : e.code() == ErrorCode::kNotFound ? ApiCode::kNotFound : ApiCode::kInternal;
      WriteError(res, code, e.what(), request_id);
    } catch (const std::exception& e) {
      MD_LOG(kError, "request_id=" << request_id << " internal error: " << e.what());
      WriteError(res, ApiCode::kInternal, "internal error (see server log, request " + request_id + ")", request_id);
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    service.metrics().CountRequest(route, res.status, seconds);
    MD_LOG(kInfo, "request_id=" << request_id << " method=" << req.method << " route=" << route
                                << " path=" << req.path << " status=" << res.status << " role=" << role
                                << " ms=" << std::lround(seconds * 1000) << " bytes_in=" << req.body.size()
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
                                                  " bytes exceeds the limit of " + std::to_string(limit));
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
    throw ApiError(ApiCode::kInvalidArgument, std::string("query parameter '") + name + "' is required");
  }
  char* end = nullptr;
  const double d = std::strtod(v->c_str(), &end);
  if (v->empty() || *end != '\0' || !std::isfinite(d)) {
    throw ApiError(ApiCode::kInvalidArgument, std::string("query parameter '") + name + "': not a finite number");
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
    throw ApiError(ApiCode::kInvalidArgument, std::string("query parameter '") + name + "': not an integer");
  }
  return n;
}

std::optional<int64_t> QueryVersion(const Req& req) {
  if (!req.has_param("version")) return std::nullopt;
  return QueryInt(req, "version", 0);
}

void WriteFile(Res& res, const FilePayload& p) {
  res.status = 200;
  res.set_header("X-Prior-Version", std::to_string(p.prior_version));
  res.set_content(std::string(p.bytes.begin(), p.bytes.end()), p.content_type);
}

}  // namespace

void RegisterRoutes(httplib::Server& s, MapService& svc) {
  const HttpConfig& cfg = svc.config().http;
  const int64_t json_limit = cfg.max_body_bytes;
  const int64_t keyframe_limit = cfg.max_keyframe_bytes;
  const int64_t prior_limit = cfg.max_prior_bytes;
  constexpr auto V = Role::kVehicle;
  constexpr auto R = Role::kReader;
  constexpr auto A = Role::kAdmin;

  s.Get("/health", Wrap(svc, "/health", [&svc](const Req&, Res& res, std::string&) { WriteJson(res, 200, svc.Health()); }));
  s.Get("/metrics", Wrap(svc, "/metrics", [&svc](const Req&, Res& res, std::string&) {
          res.set_content(svc.RenderMetrics(), "text/plain; version=0.0.4");
        }));
  s.Get("/v1/openapi.yaml", Wrap(svc, "/v1/openapi.yaml", [](const Req&, Res& res, std::string&) {
          res.set_content(std::string(OpenApiYaml()), "application/yaml");
        }));

  // --- vehicle
  s.Post("/v1/sessions", Wrap(svc, "/v1/sessions", [&svc, json_limit](const Req& req, Res& res, std::string& role) {
           Auth(svc, req, role, {V});
           WriteJson(res, 201, svc.CreateSession(ParseJsonBody(req, json_limit)));
         }));
  s.Put(R"(/v1/sessions/([0-9]{1,18})/keyframes/([0-9]{1,18}))",
        Wrap(svc, "/v1/sessions/{id}/keyframes/{seq}", [&svc, keyframe_limit](const Req& req, Res& res, std::string& role) {
          Auth(svc, req, role, {V});
          if (static_cast<int64_t>(req.body.size()) > keyframe_limit) {
            throw ApiError(ApiCode::kPayloadTooLarge, "keyframe upload exceeds " + std::to_string(keyframe_limit) + " bytes");
          }
          if (!req.is_multipart_form_data()) {
            throw ApiError(ApiCode::kUnsupportedMedia, "Content-Type must be multipart/form-data with parts 'meta' and 'depth'");
          }
          if (!req.has_file("meta") || !req.has_file("depth")) {
            throw ApiError(ApiCode::kInvalidArgument, "multipart body needs parts 'meta' (JSON) and 'depth' (16-bit PNG)");
          }
          const Json meta = ParseApiJson(req.get_file_value("meta").content, "part 'meta'");
          const std::string& png = req.get_file_value("depth").content;
          bool created = false;
          const Json out = svc.PutKeyframe(PathInt(req, 1), PathInt(req, 2), meta, Bytes(png.begin(), png.end()), &created);
          WriteJson(res, created ? 201 : 200, out);
        }));
  s.Post(R"(/v1/sessions/([0-9]{1,18})/commit)", Wrap(svc, "/v1/sessions/{id}/commit", [&svc](const Req& req, Res& res, std::string& role) {
           Auth(svc, req, role, {V});
           WriteJson(res, 202, svc.CommitSession(PathInt(req, 1)));
         }));
  s.Get(R"(/v1/sessions/([0-9]{1,18}))", Wrap(svc, "/v1/sessions/{id}", [&svc](const Req& req, Res& res, std::string& role) {
          Auth(svc, req, role, {V, R});
          WriteJson(res, 200, svc.GetSession(PathInt(req, 1)));
        }));

  // --- prior map
  s.Get("/v1/prior/tiles", Wrap(svc, "/v1/prior/tiles", [&svc](const Req& req, Res& res, std::string& role) {
          Auth(svc, req, role, {V, R});
          WriteJson(res, 200, svc.ListPriorTilesNear(QueryDouble(req, "x", std::nullopt), QueryDouble(req, "y", std::nullopt),
                                                     QueryDouble(req, "radius", 100.0), QueryVersion(req)));
        }));
  s.Get("/v1/prior/versions", Wrap(svc, "/v1/prior/versions", [&svc](const Req& req, Res& res, std::string& role) {
          Auth(svc, req, role, {V, R});
          WriteJson(res, 200, svc.ListPriorVersions());
        }));
  s.Get(R"(/v1/prior/tiles/([-0-9_]{3,24}))", Wrap(svc, "/v1/prior/tiles/{tile}", [&svc](const Req& req, Res& res, std::string& role) {
          Auth(svc, req, role, {V, R});
          WriteFile(res, svc.GetPriorTile(req.matches[1], QueryVersion(req), Query(req, "format").value_or("pcd")));
        }));

  // --- changes
  s.Get("/v1/changes/tiles", Wrap(svc, "/v1/changes/tiles", [&svc](const Req& req, Res& res, std::string& role) {
          Auth(svc, req, role, {R});
          const auto bbox = Query(req, "bbox");
          if (!bbox) throw ApiError(ApiCode::kInvalidArgument, "query parameter 'bbox' is required");
          WriteJson(res, 200, svc.ListChangedTiles(*bbox, QueryDouble(req, "min_confidence", 0.0),
                                                   QueryInt(req, "page", 1), QueryInt(req, "page_size", 100),
                                                   QueryInt(req, "min_support", 0)));
        }));
  s.Get(R"(/v1/changes/tiles/([-0-9_]{3,24}))", Wrap(svc, "/v1/changes/tiles/{tile}", [&svc](const Req& req, Res& res, std::string& role) {
          Auth(svc, req, role, {R});
          WriteFile(res, svc.GetTileChanges(req.matches[1], Query(req, "format").value_or("json"),
                                            Query(req, "kind").value_or(""), QueryDouble(req, "min_confidence", 0.0),
                                            QueryInt(req, "min_support", 0)));
        }));
  s.Get(R"(/v1/observed/tiles/([-0-9_]{3,24})\.bt)", Wrap(svc, "/v1/observed/tiles/{tile}.bt", [&svc](const Req& req, Res& res, std::string& role) {
          Auth(svc, req, role, {R});
          WriteFile(res, svc.GetObservedTile(req.matches[1]));
        }));

  // --- admin
  s.Post("/v1/admin/prior", Wrap(svc, "/v1/admin/prior", [&svc, prior_limit](const Req& req, Res& res, std::string& role) {
           Auth(svc, req, role, {A});
           if (static_cast<int64_t>(req.body.size()) > prior_limit) {
             throw ApiError(ApiCode::kPayloadTooLarge, "prior upload exceeds " + std::to_string(prior_limit) + " bytes");
           }
           if (req.get_header_value("Content-Type") != "application/octet-stream") {
             throw ApiError(ApiCode::kUnsupportedMedia, "Content-Type must be application/octet-stream");
           }
           const auto format = Query(req, "format");
           if (!format) throw ApiError(ApiCode::kInvalidArgument, "query parameter 'format' (pcd or ply) is required");
           WriteJson(res, 201, svc.ImportPrior(Bytes(req.body.begin(), req.body.end()), *format,
                                               Query(req, "note").value_or("")));
         }));
  s.Post("/v1/admin/jobs", Wrap(svc, "/v1/admin/jobs", [&svc, json_limit](const Req& req, Res& res, std::string& role) {
           Auth(svc, req, role, {A});
           WriteJson(res, 202, svc.CreateJob(ParseJsonBody(req, json_limit)));
         }));
  s.Get("/v1/admin/jobs", Wrap(svc, "/v1/admin/jobs", [&svc](const Req& req, Res& res, std::string& role) {
          Auth(svc, req, role, {A});
          WriteJson(res, 200, svc.ListJobs(QueryInt(req, "page", 1), QueryInt(req, "page_size", 50)));
        }));
  s.Get(R"(/v1/admin/jobs/([0-9]{1,18}))", Wrap(svc, "/v1/admin/jobs/{id}", [&svc](const Req& req, Res& res, std::string& role) {
          Auth(svc, req, role, {A});
          WriteJson(res, 200, svc.GetJob(PathInt(req, 1)));
        }));
  s.Post(R"(/v1/admin/jobs/([0-9]{1,18})/cancel)", Wrap(svc, "/v1/admin/jobs/{id}/cancel", [&svc](const Req& req, Res& res, std::string& role) {
           Auth(svc, req, role, {A});
           WriteJson(res, 200, svc.CancelJob(PathInt(req, 1)));
         }));

  // Body limits per route, checked on Content-Length before the body is read (so that a
  // JSON endpoint never buffers a prior-sized body). The handlers check again after reading.
  s.set_pre_routing_handler([&svc, json_limit, keyframe_limit, prior_limit](const Req& req, Res& res) {
    if (!req.has_header("Content-Length")) return httplib::Server::HandlerResponse::Unhandled;
    const int64_t limit = req.path == "/v1/admin/prior" ? prior_limit
                          : req.method == "PUT"         ? keyframe_limit
                                                        : json_limit;
    const uint64_t length = std::strtoull(req.get_header_value("Content-Length").c_str(), nullptr, 10);
    if (length <= static_cast<uint64_t>(limit)) return httplib::Server::HandlerResponse::Unhandled;
    const std::string request_id = RequestId(req);
    res.set_header("X-Request-Id", request_id);
    WriteError(res, ApiCode::kPayloadTooLarge,
               "body of " + std::to_string(length) + " bytes exceeds this route's limit of " + std::to_string(limit),
               request_id);
    svc.metrics().CountRequest("(body too large)", res.status, 0);
    MD_LOG(kInfo, "request_id=" << request_id << " method=" << req.method << " path=" << req.path
                                << " status=413 bytes_declared=" << length);
    return httplib::Server::HandlerResponse::Handled;
  });

  // Anything httplib answers by itself (unknown route, body over the global limit) gets the
  // same JSON error shape.
  s.set_error_handler([](const Req& req, Res& res) {
    if (!res.body.empty()) return;  // a handler already wrote an error
    ApiCode code = ApiCode::kInternal;
    std::string message = "request failed";
    if (res.status == 404) code = ApiCode::kNotFound, message = "no route for " + req.method + " " + req.path;
    else if (res.status == 413) code = ApiCode::kPayloadTooLarge, message = "body exceeds the server's limit";
    else if (res.status == 400) code = ApiCode::kInvalidArgument, message = "malformed HTTP request";
    else if (res.status == 405) code = ApiCode::kNotFound, message = "method not allowed";
    const int status = res.status;
    WriteError(res, code, message, RequestId(req));
    if (status == 405 || status == 400) res.status = status;
  });
}

}  // namespace mapdelta::server
