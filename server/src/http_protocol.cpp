// HTTP-layer behaviour around the routes, where cpp-httplib 0.11 (Debian 12) falls short:
// request framing and Range before routing, and the JSON error shape, X-Request-Id and a log
// line for every response httplib produces by itself.
#include <cstdlib>
#include <string>
#include <utility>

#include "http_common.hpp"
#include "http_routes.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/server/map_service.hpp"

#include <httplib.h>  // last: its <resolv.h> defines macros that break Eigen

namespace mapdelta::server {
namespace {

using Req = httplib::Request;
using Res = httplib::Response;

// httplib 0.11 reads the body of every POST/PUT/PATCH; without Content-Length or
// Transfer-Encoding it reads until the peer closes (read_content_without_length, meant for
// HTTP/1.0 responses). curl keeps the connection open for the answer, so a body-less
// `curl -X POST .../commit` waited for the read timeout and got 400. RFC 9112 section 6.3: a
// request with neither header has a body of length zero; saying so makes httplib read nothing.
void FrameBodylessRequest(Req& req) {
  if (!req.has_header("Content-Length") && !req.has_header("Transfer-Encoding")) {
    req.set_header("Content-Length", "0");
  }
}

// The API ignores Range (RFC 9110 section 14.2 allows it; every resource here is small): httplib
// 0.11 cuts *every* response body to the requested range, error bodies included, and marks it
// 206 only when the handler left the status unset, so our handlers' 200s went out as 200 with
// a partial body. Without ranges the full body goes out with its own status, static files too.
void IgnoreRange(Req& req) { req.ranges.clear(); }

// Body limits per route, checked on Content-Length before the body is read (so that a JSON
// endpoint never buffers a prior-sized body). The handlers check again after reading.
bool RejectOversizedBody(const Req& req, Res& res, MapService& svc, const BodyLimits& limits) {
  if (!req.has_header("Content-Length")) return false;
  const int64_t limit = req.path == "/v1/admin/prior" ? limits.prior
                        : req.method == "PUT"         ? limits.keyframe
                                                      : limits.json;
  const uint64_t length =
      std::strtoull(req.get_header_value("Content-Length").c_str(), nullptr, 10);
  if (length <= static_cast<uint64_t>(limit)) return false;
  const std::string request_id = RequestId(req);
  WriteError(res, ApiCode::kPayloadTooLarge,
             "body of " + std::to_string(length) + " bytes exceeds this route's limit of " +
                 std::to_string(limit),
             request_id);
  svc.metrics().CountRequest("(body too large)", res.status, 0);
  MD_LOG(kInfo, "request_id=" << request_id << " method=" << req.method << " path=" << req.path
                              << " status=413 bytes_declared=" << length);
  return true;
}

// An error status httplib set by itself, in the terms of our error table.
std::pair<ApiCode, std::string> DescribeLayerError(int status, const Req& req) {
  switch (status) {
    case 400:
      return {ApiCode::kInvalidArgument, "malformed HTTP request"};
    case 404:
      return {ApiCode::kNotFound, "no route for " + req.method + " " + req.path};
    case 405:
      return {ApiCode::kNotFound, "method not allowed"};
    case 413:
      return {ApiCode::kPayloadTooLarge, "body exceeds the server's limit"};
    case 414:
      return {ApiCode::kInvalidArgument, "request URI longer than 8192 bytes"};
    case 416:
      return {ApiCode::kInvalidArgument, "malformed Range header (bytes=first-last expected)"};
    default:
      return {ApiCode::kInternal, "request failed"};
  }
}

}  // namespace

void InstallProtocolHandlers(httplib::Server& s, MapService& svc, const BodyLimits& limits) {
  s.set_pre_routing_handler([&svc, limits](const Req& const_req, Res& res) {
    // httplib hands its own, non-const Request object to this hook and routes that same
    // object next: the framing and Range fixes have to change it before httplib reads on.
    Req& req = const_cast<Req&>(const_req);
    IgnoreRange(req);
    FrameBodylessRequest(req);
    return RejectOversizedBody(req, res, svc, limits) ? httplib::Server::HandlerResponse::Handled
                                                      : httplib::Server::HandlerResponse::Unhandled;
  });

  // Anything httplib answers by itself (unknown route, malformed request line or headers,
  // unparsable Range, body over the global limit) gets the same JSON error shape, a request
  // id and a log line.
  s.set_error_handler([&svc](const Req& req, Res& res) {
    if (!res.body.empty()) return;  // a handler already wrote an error
    const int status = res.status;
    const auto [code, message] = DescribeLayerError(status, req);
    const std::string request_id = RequestId(req);
    WriteError(res, code, message, request_id);
    res.status = status;  // httplib's status stands (the table has no 405, 414, 416)
    svc.metrics().CountRequest("(http layer)", res.status, 0);
    MD_LOG(kInfo, "request_id=" << request_id << " method=" << req.method << " path=" << req.path
                                << " status=" << res.status << " answered by the HTTP layer");
  });

  // Every response leaves through here, including the web map's static files: each carries a
  // request id and says that ranges are not served (see IgnoreRange). httplib marks a static
  // file 206 when the request had a Range, even with the ranges dropped and the whole body
  // going out: that is a 200.
  s.set_post_routing_handler([](const Req& req, Res& res) {
    if (!res.has_header("X-Request-Id")) res.set_header("X-Request-Id", RequestId(req));
    if (res.status == 206 && !res.has_header("Content-Range")) res.status = 200;
    res.headers.erase("Accept-Ranges");
    res.set_header("Accept-Ranges", "none");
  });
}

}  // namespace mapdelta::server
