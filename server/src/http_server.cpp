// HTTP adapter: server life cycle (socket, limits, routes, protocol handlers).
#include "mapdelta/server/http_server.hpp"

#include <sys/socket.h>

#include <cerrno>
#include <cstring>

#include "http_routes.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"

#include <httplib.h>  // last: its <resolv.h> defines macros that break Eigen

namespace mapdelta::server {

namespace {
constexpr size_t kKeepAliveMaxRequests = 10;
}  // namespace

struct HttpServer::Impl {
  explicit Impl(MapService& s) : service(s) {}
  MapService& service;
  httplib::Server server;
  int listen_socket = -1;  // the last socket httplib made to bind (the listening one on success)
};

HttpServer::HttpServer(MapService& service) : impl_(std::make_unique<Impl>(service)) {
  const HttpConfig& c = service.config().http;
  httplib::Server& s = impl_->server;
  const int threads = c.threads;
  s.new_task_queue = [threads] { return new httplib::ThreadPool(static_cast<size_t>(threads)); };
  // The largest body any route accepts; routes check their own, smaller limits.
  s.set_payload_max_length(
      static_cast<size_t>(std::max({c.max_body_bytes, c.max_keyframe_bytes, c.max_prior_bytes})));
  s.set_read_timeout(c.read_timeout_s, 0);
  s.set_write_timeout(c.write_timeout_s, 0);
  // httplib keeps a worker on one keep-alive connection until it has made this many requests,
  // so with more busy clients than workers the others wait for that long: a small count
  // hands the worker on after a few requests (a loopback reconnect costs ~0.1 ms).
  s.set_keep_alive_max_count(kKeepAliveMaxRequests);
  // Idle keep-alive connections hold up a graceful stop this long at most.
  s.set_keep_alive_timeout(2);
  // httplib's default socket options add SO_REUSEPORT, with which a second server binds the
  // same port without an error and the kernel splits the connections between the two.
  // SO_REUSEADDR alone still allows a restart while old connections are in TIME_WAIT.
  s.set_socket_options([impl = impl_.get()](socket_t sock) {
    const int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
    impl->listen_socket = sock;
  });
  RegisterRoutes(s, service);
  InstallProtocolHandlers(s, service,
                          BodyLimits{c.max_body_bytes, c.max_keyframe_bytes, c.max_prior_bytes});
}

HttpServer::~HttpServer() { Stop(); }

int HttpServer::Bind(const std::string& address, int port) {
  int bound = port;
  errno = 0;
  if (port == 0)
    bound = impl_->server.bind_to_any_port(address);
  else if (!impl_->server.bind_to_port(address, port))
    bound = -1;
  // The system's httplib library listens with a backlog of 5 (CPPHTTPLIB_LISTEN_BACKLOG is
  // compiled into it): a burst of connects while the accept thread waits for the CPU overflows
  // that queue, and the kernel drops SYNs (a load run lost 2 POST /v1/sessions so). Linux takes
  // a second listen() on a listening socket as a new backlog; the kernel caps it at
  // net.core.somaxconn.
  if (bound > 0 && ::listen(impl_->listen_socket, SOMAXCONN) != 0) {
    const std::string reason = std::strerror(errno);
    throw Error(ErrorCode::kIo, "cannot set the listen backlog on " + address + ":" +
                                    std::to_string(bound) + ": " + reason);
  }
  if (bound <= 0) {
    // httplib reports only failure; errno is what its last bind()/listen() left.
    const std::string reason = errno != 0 ? std::strerror(errno) : "address not usable";
    throw Error(ErrorCode::kIo,
                "cannot listen on " + address + ":" + std::to_string(port) + ": " + reason);
  }
  return bound;
}

void HttpServer::Run() { impl_->server.listen_after_bind(); }

bool HttpServer::MountWebRoot(const std::string& dir) {
  // httplib answers GET/HEAD from mounted files before the routes; the API has no files there.
  return impl_->server.set_mount_point("/", dir);
}

void HttpServer::Stop() {
  if (impl_->server.is_running()) impl_->server.stop();
}

}  // namespace mapdelta::server
