#pragma once
// Samples the server's resident set size (VmRSS in /proc/PID/status) at a fixed interval on its
// own thread, for the memory-over-time line of a load run. The pid is read from a pid file at
// every tick, so a server restarted by the crash soak is followed; a killed one just yields no
// sample for that tick.
#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "support/rss.hpp"

namespace mapdelta::bench {

struct RssSample {
  double t_s = 0;
  int64_t rss_kib = 0;
};

class RssSampler {
 public:
  RssSampler(std::string pid_file, double interval_s)
      : pid_file_(std::move(pid_file)), interval_(interval_s) {
    if (!pid_file_.empty()) thread_ = std::thread([this] { Run(); });
  }
  ~RssSampler() { Stop(); }
  void Stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  std::vector<RssSample> samples() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return samples_;
  }

 private:
  void Run() {
    const auto t0 = std::chrono::steady_clock::now();
    while (!stop_) {
      pid_t pid = 0;
      std::ifstream(pid_file_) >> pid;
      const int64_t kib = pid > 0 ? mapdelta::testing::ReadRssKib(pid) : -1;
      const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (kib >= 0) {
        std::lock_guard<std::mutex> lock(mutex_);
        samples_.push_back({t, kib});
      }
      for (double slept = 0; slept < interval_ && !stop_; slept += 0.05) {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
    }
  }

  std::string pid_file_;
  double interval_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::vector<RssSample> samples_;
  std::thread thread_;
};

}  // namespace mapdelta::bench
