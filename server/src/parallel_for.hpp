#pragma once
// A small fork-join loop for the jobs: no thread pool lives between jobs (a job runs for
// seconds, thread start-up costs microseconds).
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace mapdelta::server {

// Runs fn(i) for i in [0, n) on `threads` workers (the calling thread is one of them), each
// claiming the next index; after the first error no new index is claimed, and that error is
// rethrown here. Indices run in any order: fn must write only to its own slot.
inline void ParallelFor(int64_t n, int threads, const std::function<void(int64_t)>& fn) {
  std::atomic<int64_t> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto work = [&] {
    while (!failed) {
      const int64_t i = next++;
      if (i >= n) return;
      try {
        fn(i);
      } catch (...) {
        std::lock_guard lock(error_mutex);
        if (!error) error = std::current_exception();
        failed = true;
      }
    }
  };
  std::vector<std::thread> pool;
  for (int64_t w = 1; w < std::min<int64_t>(threads, n); ++w) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace mapdelta::server
