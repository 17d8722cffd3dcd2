#pragma once
// The client's view of the server's REST API (docs/api.md), as an interface so the uploader
// and prior fetcher are testable without sockets. The cpp-httplib implementation lives in
// http_transport.cpp only (httplib.h must never reach a header: see DESIGN.md pitfalls).
#include <memory>
#include <string>

namespace mapdelta::client {

struct HttpResponse {
  int status = 0;  // 0: no response (connection refused, timeout, ...)
  std::string body;
  std::string error;  // transport error text when status == 0
  bool Ok() const { return status >= 200 && status < 300; }
  // Worth retrying later: no response, 5xx, or 429.
  bool Transient() const { return status == 0 || status >= 500 || status == 429; }
};

class HttpTransport {
 public:
  virtual ~HttpTransport() = default;
  virtual HttpResponse Get(const std::string& path) = 0;
  virtual HttpResponse PostJson(const std::string& path, const std::string& json) = 0;
  // multipart/form-data with parts "meta" (application/json) and "depth" (image/png).
  virtual HttpResponse PutKeyframe(const std::string& path, const std::string& meta_json,
                                   const std::string& depth_png) = 0;
};

// base_url: "http://host:port" (https if the build's httplib supports it). Every request
// carries "Authorization: Bearer <token>". Throws Error(kInvalidArgument) on a bad URL.
std::unique_ptr<HttpTransport> MakeHttpTransport(const std::string& base_url,
                                                 const std::string& token, double timeout_s);

}  // namespace mapdelta::client
