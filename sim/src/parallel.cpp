#include "mapdelta/sim/parallel.hpp"

#include <chrono>
#include <mutex>

#include "mapdelta/common/parallel.hpp"

namespace mapdelta::sim {

void ParallelFor(size_t n, int threads, const std::string& stage, const ProgressFn& progress,
                 const std::function<void(size_t)>& job) {
  constexpr auto kProgressEvery = std::chrono::milliseconds(100);
  std::mutex progress_mutex;
  size_t done = 0;
  auto last_report = std::chrono::steady_clock::now();
  mapdelta::ParallelFor(n, threads, [&](size_t i) {
    job(i);
    if (!progress) return;
    const std::lock_guard lock(progress_mutex);
    ++done;
    const auto now = std::chrono::steady_clock::now();
    if (now - last_report < kProgressEvery) return;
    last_report = now;
    progress(stage, done, n);
  });
  if (progress) progress(stage, n, n);
}

}  // namespace mapdelta::sim
