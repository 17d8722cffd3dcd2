// The only file of mapdelta_client that includes httplib.h (last, after everything else:
// its <resolv.h> defines macros that break Eigen headers included after it).
#include "mapdelta/client/http_transport.hpp"

#include <chrono>

#include "mapdelta/common/error.hpp"

#include <httplib.h>

namespace mapdelta::client {
namespace {

HttpResponse Convert(const httplib::Result& result) {
  HttpResponse r;
  if (!result) {
    r.error = httplib::to_string(result.error());
    return r;
  }
  r.status = result->status;
  r.body = result->body;
  return r;
}

class HttplibTransport : public HttpTransport {
 public:
  HttplibTransport(const std::string& base_url, const std::string& token, double timeout_s)
      : client_(base_url), headers_{{"Authorization", "Bearer " + token}} {
    if (!client_.is_valid())
      throw Error(ErrorCode::kInvalidArgument, "bad server URL '" + base_url + "'");
    const auto timeout = std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1000));
    client_.set_connection_timeout(timeout);
    client_.set_read_timeout(timeout);
    client_.set_write_timeout(timeout);
  }
  HttpResponse Get(const std::string& path) override {
    return Convert(client_.Get(path, headers_));
  }
  HttpResponse PostJson(const std::string& path, const std::string& json) override {
    return Convert(client_.Post(path, headers_, json, "application/json"));
  }
  HttpResponse PutKeyframe(const std::string& path, const std::string& meta_json,
                           const std::string& depth_png) override {
    const httplib::MultipartFormDataItems items = {
        {"meta", meta_json, "meta.json", "application/json"},
        {"depth", depth_png, "depth.png", "image/png"},
    };
    return Convert(client_.Put(path, headers_, items));
  }

 private:
  httplib::Client client_;
  httplib::Headers headers_;
};

}  // namespace

std::unique_ptr<HttpTransport> MakeHttpTransport(const std::string& base_url,
                                                 const std::string& token, double timeout_s) {
  return std::make_unique<HttplibTransport>(base_url, token, timeout_s);
}

}  // namespace mapdelta::client
