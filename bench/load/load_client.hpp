#pragma once
// One driver thread's HTTP connection to the server under load (httplib stays in the .cpp).
// Every request is timed into the shared LatencyBook under its route name. With retry on (the
// crash soak), a request that gets no answer or a 503 is repeated until it is answered or
// the deadline passes: the server is being killed and restarted under it.
#include <chrono>
#include <memory>
#include <string>

#include "latency_book.hpp"

namespace mapdelta::bench {

struct Answer {
  int status = 0;  // 0 = no answer before the deadline
  std::string body;
};

struct MultipartKeyframe {
  std::string meta_json;
  std::string png;
};

class LoadClient {
 public:
  using Deadline = std::chrono::steady_clock::time_point;
  LoadClient(const std::string& host, int port, LatencyBook* book, bool retry, Deadline deadline);
  ~LoadClient();

  Answer Get(const std::string& route, const std::string& path, const std::string& token);
  Answer PostJson(const std::string& route, const std::string& path, const std::string& token,
                  const std::string& json);
  Answer PutKeyframe(const std::string& route, const std::string& path, const std::string& token,
                     const MultipartKeyframe& keyframe);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mapdelta::bench
