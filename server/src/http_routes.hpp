#pragma once
// Route registration for the HTTP adapter. httplib is only forward-declared here.
namespace httplib {
class Server;
}

namespace mapdelta::server {
class MapService;
void RegisterRoutes(httplib::Server& server, MapService& service);
}  // namespace mapdelta::server
