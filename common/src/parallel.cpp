#include "mapdelta/common/parallel.hpp"

#include <exception>

namespace mapdelta {
namespace {

// Set while this thread runs a job of a team that runs on several threads (the caller's t = 0
// included): loops started there run serially.
thread_local bool inside_parallel_loop = false;

class InsideLoopScope {
 public:
  InsideLoopScope() : previous_(inside_parallel_loop) { inside_parallel_loop = true; }
  ~InsideLoopScope() { inside_parallel_loop = previous_; }
  InsideLoopScope(const InsideLoopScope&) = delete;
  InsideLoopScope& operator=(const InsideLoopScope&) = delete;

 private:
  const bool previous_;
};

// The calling thread's team with at least num_threads threads (created or grown on demand,
// kept until the thread exits).
detail::ThreadTeam& CallerTeam(int num_threads) {
  thread_local std::unique_ptr<detail::ThreadTeam> team;
  if (!team || team->size() < num_threads) team = std::make_unique<detail::ThreadTeam>(num_threads);
  return *team;
}

}  // namespace

int ResolveThreads(int requested) {
  if (requested > 0) return requested;
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

bool InsideParallelLoop() { return inside_parallel_loop; }

void RunOnThreads(int threads, const std::function<void(int t)>& worker) {
  if (threads <= 1 || inside_parallel_loop) {
    worker(0);
    return;
  }
  CallerTeam(threads).Run(threads, worker);
}

void ParallelFor(size_t n, int threads, const std::function<void(size_t i)>& body, size_t grain) {
  grain = std::max<size_t>(1, grain);
  const size_t blocks = n / grain + (n % grain != 0);
  const int used =
      static_cast<int>(std::min<size_t>(blocks, static_cast<size_t>(std::max(1, threads))));
  std::atomic<size_t> next{0};
  std::atomic<bool> failed{false};
  RunOnThreads(used, [&](int) {
    while (!failed) {
      const size_t b = next++;
      if (b >= blocks) return;
      try {
        for (size_t i = b * grain, end = std::min(n, i + grain); i < end; ++i) body(i);
      } catch (...) {
        failed = true;
        throw;
      }
    }
  });
}

namespace detail {

ThreadTeam::ThreadTeam(int num_threads) : size_(std::max(1, num_threads)) {
  for (int t = 1; t < size_; ++t) workers_.emplace_back([this, t] { Work(t); });
}

ThreadTeam::~ThreadTeam() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (auto& w : workers_) w.join();
}

void ThreadTeam::Run(int threads, const std::function<void(int)>& job) {
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
  {
    std::lock_guard<std::mutex> lock(mutex_);
    job_ = guarded;
    active_ = threads;
    pending_ = threads - 1;
    ++generation_;
  }
  wake_.notify_all();
  {
    const InsideLoopScope inside;
    guarded(0);
  }
  {
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return pending_ == 0; });
    job_ = nullptr;
  }
  busy_ = false;
  for (const auto& e : errors) {
    if (e) std::rethrow_exception(e);
  }
}

void ThreadTeam::Work(int t) {
  inside_parallel_loop = true;  // this thread only ever runs loop bodies
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

}  // namespace detail
}  // namespace mapdelta
