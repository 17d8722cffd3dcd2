#pragma once
// The HTTP adapter over MapService (cpp-httplib stays inside its .cpp files).
#include <memory>
#include <string>

#include "mapdelta/server/map_service.hpp"

namespace mapdelta::server {

class HttpServer {
 public:
  explicit HttpServer(MapService& service);
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  // Binds the listening socket; port 0 picks a free port. Returns the bound port.
  // Throws Error(kIo) if the address cannot be bound.
  int Bind(const std::string& address, int port);
  // Serves until Stop(); in-flight requests finish first.
  void Run();
  void Stop();
  // Web map (web/, built by tools/build-web.sh): serves DIR's files at `/` beside the API.
  // Returns false if DIR is not a directory.
  bool MountWebRoot(const std::string& dir);

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace mapdelta::server
