#pragma once
// Route and protocol-handler registration for the HTTP adapter. httplib is only
// forward-declared here.
#include <cstdint>

namespace httplib {
class Server;
}

namespace mapdelta::server {
class MapService;

// Largest accepted body per kind of route, in bytes (from HttpConfig).
struct BodyLimits {
  int64_t json = 0;
  int64_t keyframe = 0;
  int64_t prior = 0;
};

void RegisterRoutes(httplib::Server& server, MapService& service);
// Before routing: body-less requests framed, Range ignored, oversized bodies refused; after:
// errors httplib answers by itself get the JSON shape; every response gets X-Request-Id.
void InstallProtocolHandlers(httplib::Server& server, MapService& service,
                             const BodyLimits& limits);
}  // namespace mapdelta::server
