#include "http_common.hpp"

#include <algorithm>
#include <cctype>

#include "auth.hpp"
#include "mapdelta/server/map_service.hpp"

#include <httplib.h>  // last: its <resolv.h> defines macros that break Eigen

namespace mapdelta::server {

void WriteError(httplib::Response& res, ApiCode code, const std::string& message,
                const std::string& request_id) {
  const ApiErrorInfo& info = Info(code);
  res.status = info.http_status;
  const Json body{
      {"error", {{"code", info.name}, {"message", message}, {"request_id", request_id}}}};
  res.set_content(body.dump(), "application/json");
  res.headers.erase("X-Request-Id");  // set_header appends: keep exactly one
  res.set_header("X-Request-Id", request_id);
}

std::string RequestId(const httplib::Request& req) {
  std::string id = req.get_header_value("X-Request-Id");
  const bool ok = !id.empty() && id.size() <= 64 && std::all_of(id.begin(), id.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_';
  });
  return ok ? id : RandomHex(8);
}

}  // namespace mapdelta::server
