#pragma once
// Splits [0, n) into contiguous ranges, runs body(begin, end, accumulator) on each in its own
// thread, and returns the accumulators in range order. The split depends only on n and the
// thread count, so sums combined in order are deterministic for a given thread count.
// std::thread rather than OpenMP: nothing process-wide is touched, and on an oversubscribed
// machine libgomp's spin-waiting barriers made 2-thread runs 10x slower than 1 thread
// (measured with bench_registration at load ~8 on 2 cores), while burning others' CPU.
//
// ThreadTeam keeps its workers for many ParallelRanges calls (AlignGicp's passes): starting a
// std::thread per pass cost ~30-60 us each, 8-10 times per alignment. Idle workers block on a
// condition variable; they never spin.
#include <algorithm>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace mapdelta::detail {

class ThreadTeam {
 public:
  explicit ThreadTeam(int num_threads) : size_(std::max(1, num_threads)) {
    for (int t = 1; t < size_; ++t) workers_.emplace_back([this, t] { Work(t); });
  }
  ~ThreadTeam() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (auto& w : workers_) w.join();
  }
  ThreadTeam(const ThreadTeam&) = delete;
  ThreadTeam& operator=(const ThreadTeam&) = delete;

  int size() const { return size_; }

  // Runs job(t) for t in [0, threads) (threads <= size(); t = 0 on the calling thread) and
  // returns when all are done. Exceptions are caught per job; the first is rethrown here.
  void Run(int threads, const std::function<void(int)>& job) {
    threads = std::clamp(threads, 1, size_);
    std::vector<std::exception_ptr> errors(static_cast<size_t>(threads));
    auto guarded = [&](int t) {
      try {
        job(t);
      } catch (...) {
        errors[static_cast<size_t>(t)] = std::current_exception();
      }
    };
    if (threads > 1) {
      std::lock_guard<std::mutex> lock(mutex_);
      job_ = guarded;
      active_ = threads;
      pending_ = threads - 1;
      ++generation_;
    }
    wake_.notify_all();
    guarded(0);
    if (threads > 1) {
      std::unique_lock<std::mutex> lock(mutex_);
      done_.wait(lock, [this] { return pending_ == 0; });
      job_ = nullptr;
    }
    for (const auto& e : errors) {
      if (e) std::rethrow_exception(e);
    }
  }

 private:
  void Work(int t) {
    size_t seen = 0;
    while (true) {
      std::function<void(int)> job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
        if (t >= active_) continue;  // this job needs fewer threads
        job = job_;
      }
      job(t);
      std::lock_guard<std::mutex> lock(mutex_);
      if (--pending_ == 0) done_.notify_one();
    }
  }

  const int size_;
  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  std::function<void(int)> job_;
  size_t generation_ = 0;
  int active_ = 0;
  int pending_ = 0;
  bool stop_ = false;
};

inline constexpr size_t kMinPerThread = 512;  // below this, a thread costs more than it saves

template <class Accumulator, class Body>
std::vector<Accumulator> ParallelRanges(size_t n, ThreadTeam& team, const Accumulator& init,
                                        Body&& body) {
  const size_t by_size = std::max<size_t>(1, n / kMinPerThread);
  const size_t threads = std::min<size_t>(static_cast<size_t>(team.size()), by_size);
  std::vector<Accumulator> accumulators(threads, init);
  team.Run(static_cast<int>(threads), [&](int t) {
    const size_t k = static_cast<size_t>(t);
    body(n * k / threads, n * (k + 1) / threads, accumulators[k]);
  });
  return accumulators;
}

// One-off: a team for this call only.
template <class Accumulator, class Body>
std::vector<Accumulator> ParallelRanges(size_t n, int num_threads, const Accumulator& init,
                                        Body&& body) {
  const int threads =
      static_cast<int>(std::min<size_t>(static_cast<size_t>(std::max(1, num_threads)),
                                        std::max<size_t>(1, n / kMinPerThread)));
  ThreadTeam team(threads);
  return ParallelRanges(n, team, init, std::forward<Body>(body));
}

}  // namespace mapdelta::detail
