#pragma once
// Splits [0, n) into num_threads contiguous ranges, runs body(begin, end, accumulator) on each
// in its own std::thread, and returns the accumulators in range order. The split depends only
// on n and num_threads, so sums combined in order are deterministic for a given thread count.
// std::thread rather than OpenMP: nothing process-wide is touched, and on an oversubscribed
// machine libgomp's spin-waiting barriers made 2-thread runs 10x slower than 1 thread
// (measured with bench_registration at load ~8 on 2 cores), while burning others' CPU.
#include <algorithm>
#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

namespace mapdelta::detail {

template <class Accumulator, class Body>
std::vector<Accumulator> ParallelRanges(size_t n, int num_threads, const Accumulator& init,
                                        Body&& body) {
  constexpr size_t kMinPerThread = 512;  // below this, a thread costs more than it saves
  const size_t by_size = std::max<size_t>(1, n / kMinPerThread);
  const size_t threads = std::min<size_t>(std::max(1, num_threads), by_size);
  std::vector<Accumulator> accumulators(threads, init);
  std::vector<std::exception_ptr> errors(threads);
  auto run = [&](size_t t) {
    try {
      body(n * t / threads, n * (t + 1) / threads, accumulators[t]);
    } catch (...) {
      errors[t] = std::current_exception();
    }
  };
  std::vector<std::thread> workers;
  workers.reserve(threads - 1);
  for (size_t t = 1; t < threads; ++t) workers.emplace_back(run, t);
  run(0);
  for (auto& w : workers) w.join();
  for (const auto& e : errors) {
    if (e) std::rethrow_exception(e);
  }
  return accumulators;
}

}  // namespace mapdelta::detail
