#pragma once
// Parallel loops for GICP over chunks of [0, n) (ParallelRanges below), with per-chunk
// accumulators summed in order: deterministic, and the same for any thread count.
// std::thread rather than OpenMP: nothing process-wide is touched, and on an oversubscribed
// machine libgomp's spin-waiting barriers made 2-thread runs 10x slower than 1 thread
// (measured with bench_registration at load ~8 on 2 cores), while burning others' CPU.
//
// The workers are kept between calls, one team per calling thread (CallerTeam): on a shared,
// loaded machine a freshly started std::thread waited up to several ms for a core (the
// scheduler makes new threads queue behind running ones), and two clouds prepared on a new
// thread each took longer than one after the other. A woken worker starts at once. Idle
// workers block on a condition variable; they never spin.
#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <memory>
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
  bool busy() const { return busy_; }

  // Runs job(t) for t in [0, threads) (threads <= size(); t = 0 on the calling thread) and
  // returns when all are done. Exceptions are caught per job; the first is rethrown here.
  // A Run from inside a job of the same team runs its jobs one after the other on the caller.
  void Run(int threads, const std::function<void(int)>& job) {
    threads = busy_ ? 1 : std::clamp(threads, 1, size_);
    if (threads == 1) {
      job(0);
      return;
    }
    busy_ = true;
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
    busy_ = false;
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
  bool busy_ = false;  // only the owning thread reads or writes it
  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  std::function<void(int)> job_;
  size_t generation_ = 0;
  int active_ = 0;
  int pending_ = 0;
  bool stop_ = false;
};

// Points per chunk of ParallelRanges: small enough to balance uneven work (the k-d tree
// search of a point costs from ~0.1 to several us), large enough that taking one is free.
inline constexpr size_t kChunk = 256;

// The calling thread's team with at least num_threads threads (created or grown on demand,
// kept until the thread exits; not grown while it runs a job, which then runs serially).
inline ThreadTeam& CallerTeam(int num_threads) {
  thread_local std::unique_ptr<ThreadTeam> team;
  if (!team || (team->size() < num_threads && !team->busy())) {
    team = std::make_unique<ThreadTeam>(num_threads);
  }
  return *team;
}

// Splits [0, n) into chunks of ~kChunk (their number depends on n only), which num_threads
// threads of the caller's team take in turn; body(begin, end, accumulator) runs once per
// chunk with that chunk's accumulator. The accumulators come back in chunk order, so sums
// combined in order are the same for any thread count.
template <class Accumulator, class Body>
std::vector<Accumulator> ParallelRanges(size_t n, int num_threads, const Accumulator& init,
                                        Body&& body) {
  const size_t chunks = std::max<size_t>(1, n / kChunk);
  const int threads =
      static_cast<int>(std::min<size_t>(chunks, static_cast<size_t>(std::max(1, num_threads))));
  std::vector<Accumulator> accumulators(chunks, init);
  std::atomic<size_t> next{0};
  ThreadTeam& team = CallerTeam(threads);
  team.Run(threads, [&](int) {
    for (size_t c = next++; c < chunks; c = next++) {
      // A local accumulator: neighbouring chunks' accumulators share cache lines, and two
      // threads writing them term by term made 2 threads no faster than 1.
      Accumulator local = init;
      body(n * c / chunks, n * (c + 1) / chunks, local);
      accumulators[c] = std::move(local);
    }
  });
  return accumulators;
}

}  // namespace mapdelta::detail
