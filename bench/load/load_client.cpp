#include "load_client.hpp"

#include <functional>
#include <thread>

#include <httplib.h>  // last: its <resolv.h> defines macros that break Eigen

namespace mapdelta::bench {

struct LoadClient::Impl {
  httplib::Client client;
  LatencyBook* book;
  bool retry;
  Deadline deadline;

  Impl(const std::string& host, int port, LatencyBook* b, bool r, Deadline d)
      : client(host, port), book(b), retry(r), deadline(d) {
    client.set_connection_timeout(2, 0);
    client.set_read_timeout(60, 0);  // a commit or a big tile under load may take a while
    client.set_keep_alive(true);
  }

  Answer Send(const std::string& route, const std::function<httplib::Result()>& request) {
    for (;;) {
      const auto t0 = std::chrono::steady_clock::now();
      httplib::Result r = request();
      const double ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      const int status = r ? r->status : 0;
      book->Record(route, status, ms);
      const bool answered = status != 0 && status != 503;
      if (answered || !retry || std::chrono::steady_clock::now() >= deadline) {
        return {status, r ? r->body : std::string()};
      }
      // The server is down (killed) or shutting down: wait for the restart, then repeat.
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
};

LoadClient::LoadClient(const std::string& host, int port, LatencyBook* book, bool retry,
                       Deadline deadline)
    : impl_(std::make_unique<Impl>(host, port, book, retry, deadline)) {}
LoadClient::~LoadClient() = default;

Answer LoadClient::Get(const std::string& route, const std::string& path,
                       const std::string& token) {
  const httplib::Headers h{{"Authorization", token}};
  return impl_->Send(route, [&] { return impl_->client.Get(path.c_str(), h); });
}

Answer LoadClient::PostJson(const std::string& route, const std::string& path,
                            const std::string& token, const std::string& json) {
  const httplib::Headers h{{"Authorization", token}};
  return impl_->Send(route,
                     [&] { return impl_->client.Post(path.c_str(), h, json, "application/json"); });
}

Answer LoadClient::PutKeyframe(const std::string& route, const std::string& path,
                               const std::string& token, const MultipartKeyframe& keyframe) {
  const httplib::Headers h{{"Authorization", token}};
  const httplib::MultipartFormDataItems items{{"meta", keyframe.meta_json, "", "application/json"},
                                              {"depth", keyframe.png, "depth.png", "image/png"}};
  return impl_->Send(route, [&] { return impl_->client.Put(path.c_str(), h, items); });
}

}  // namespace mapdelta::bench
