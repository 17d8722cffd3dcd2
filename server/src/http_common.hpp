#pragma once
// Pieces every part of the HTTP adapter shares: the JSON error body and the request id.
// httplib is only forward-declared here (its header stays in the adapter's .cpp files).
#include <string>

#include "mapdelta/server/api_error.hpp"

namespace httplib {
struct Request;
struct Response;
}  // namespace httplib

namespace mapdelta::server {

// {"error": {"code", "message", "request_id"}} with the code's status, and the X-Request-Id
// header, so that the header and the body always name the same id.
void WriteError(httplib::Response& res, ApiCode code, const std::string& message,
                const std::string& request_id);
// The client's X-Request-Id if it is a sane token (1-64 of [A-Za-z0-9_-]), else a new random one.
std::string RequestId(const httplib::Request& req);

}  // namespace mapdelta::server
