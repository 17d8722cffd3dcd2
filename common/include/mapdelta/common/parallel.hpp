#pragma once
// mapdelta's one parallel layer: fork-join loops over an index range, on std::threads kept per
// calling thread, with the thread count always given by the caller (0 = every hardware thread,
// ResolveThreads). Used by change detection, metrics, registration, the server's commit and
// the simulator.
//
// Why not OpenMP: on an oversubscribed machine libgomp's spin-waiting barriers made 2-thread
// GICP runs 10x slower than 1 thread (bench_registration at load ~8 on 2 cores) while burning
// other processes' CPU; its team size is process-wide (OMP_NUM_THREADS), not the caller's; and
// an OpenMP loop inside one of the server's worker threads opened a team per worker, so a
// commit ran pipeline.threads x cores threads. Here idle workers block on a condition variable.
//
// Why the workers are kept between calls, one team per calling thread: on a shared, loaded
// machine a freshly started std::thread waited up to several ms for a core (new threads queue
// behind running ones), and GICP starts a loop per iteration.
//
// Nesting: a loop started inside the body of a loop that runs on several threads runs on its
// calling thread alone, so the outer caller's count is the whole budget (as OpenMP without
// nested parallelism). The commit classifies tiles on pipeline.threads threads, each tile's
// own loops serial inside.
#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace mapdelta {

// `requested` if > 0, else the machine's hardware threads (at least 1).
int ResolveThreads(int requested);

// True on a thread that is running the body of a loop on several threads right now.
bool InsideParallelLoop();

// Runs worker(t) on up to `threads` threads, t in [0, threads used), the calling thread as
// t = 0, and returns when all are done. Fewer threads than asked may run (inside another loop,
// or `threads` < 1), so workers must share the work themselves (e.g. claim indices from an
// atomic counter) rather than assume a share per t. The first exception (by t) is rethrown.
void RunOnThreads(int threads, const std::function<void(int t)>& worker);

// Runs body(i) for every i in [0, n) on up to `threads` threads, each claiming `grain`
// consecutive indices at a time (grain trades balance against claims: a few thousand for
// cheap per-point queries, 1 for seconds-long items). Indices run in any order: body must
// write only to its own slot. After the first exception no new indices are claimed, and that
// exception is rethrown here.
void ParallelFor(size_t n, int threads, const std::function<void(size_t i)>& body,
                 size_t grain = 1);

namespace detail {

// Worker threads kept between loops (see above). Not for direct use: RunOnThreads.
class ThreadTeam {
 public:
  explicit ThreadTeam(int num_threads);
  ~ThreadTeam();
  ThreadTeam(const ThreadTeam&) = delete;
  ThreadTeam& operator=(const ThreadTeam&) = delete;

  int size() const { return size_; }
  bool busy() const { return busy_; }

  // Runs job(t) for t in [0, threads) (threads <= size(); t = 0 on the calling thread) and
  // returns when all are done. Exceptions are caught per job; the first is rethrown here.
  void Run(int threads, const std::function<void(int)>& job);

 private:
  void Work(int t);

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

// Indices per chunk of ParallelRanges: small enough to balance uneven work (the k-d tree
// search of a point costs from ~0.1 to several us), large enough that taking one is free.
inline constexpr size_t kChunk = 256;

}  // namespace detail

// Splits [0, n) into chunks of ~detail::kChunk (their number depends on n only), which up to
// num_threads threads take in turn; body(begin, end, accumulator) runs once per chunk with that
// chunk's accumulator. The accumulators come back in chunk order, so sums combined in order
// are the same for any thread count (GICP's normal equations).
template <class Accumulator, class Body>
std::vector<Accumulator> ParallelRanges(size_t n, int num_threads, const Accumulator& init,
                                        Body&& body) {
  const size_t chunks = std::max<size_t>(1, n / detail::kChunk);
  const int threads =
      static_cast<int>(std::min<size_t>(chunks, static_cast<size_t>(std::max(1, num_threads))));
  std::vector<Accumulator> accumulators(chunks, init);
  std::atomic<size_t> next{0};
  RunOnThreads(threads, [&](int) {
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

}  // namespace mapdelta
