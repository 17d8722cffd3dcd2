// common/parallel.hpp: every index once, the caller's thread count, errors, nesting, and the
// change detection giving the same result for any thread count.
#include "mapdelta/common/parallel.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>

#include "box_scene.hpp"
#include "mapdelta/common/change_detection.hpp"

namespace mapdelta {
namespace {

TEST(Parallel, EveryIndexRunsOnceForAnyThreadCountAndGrain) {
  for (int threads : {1, 2, 3, 8}) {
    for (size_t grain : {size_t{1}, size_t{7}, size_t{5000}}) {
      std::vector<std::atomic<int>> runs(1000);
      ParallelFor(
          runs.size(), threads, [&](size_t i) { ++runs[i]; }, grain);
      for (size_t i = 0; i < runs.size(); ++i) {
        ASSERT_EQ(runs[i].load(), 1)
            << "index " << i << ", " << threads << " threads, grain " << grain;
      }
    }
  }
  ParallelFor(0, 4, [](size_t) { FAIL() << "no index in an empty range"; });
}

TEST(Parallel, UsesAtMostTheCallersThreadCount) {
  for (int threads : {1, 2, 3}) {
    std::mutex mutex;
    std::set<std::thread::id> seen;
    std::atomic<int> running{0}, most{0};
    ParallelFor(64, threads, [&](size_t) {
      const int now = ++running;
      for (int m = most; now > m && !most.compare_exchange_weak(m, now);) {
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
      --running;
      const std::lock_guard lock(mutex);
      seen.insert(std::this_thread::get_id());
    });
    EXPECT_LE(most.load(), threads);
    EXPECT_LE(seen.size(), static_cast<size_t>(threads));
    EXPECT_TRUE(seen.count(std::this_thread::get_id())) << "the caller is one of the threads";
  }
}

TEST(Parallel, FirstErrorIsRethrownAndStopsNewClaims) {
  std::atomic<size_t> ran{0};
  std::atomic<bool> thrown{false}, waited{false};
  EXPECT_THROW(ParallelFor(100000, 2,
                           [&](size_t i) {
                             ++ran;
                             if (i == 10) {
                               thrown = true;
                               throw std::runtime_error("index 10");
                             }
                             // Past index 20 the other thread waits once until the error is on
                             // its way: without this, a thread preempted before index 10 (a
                             // loaded machine) let the other run all 100000 first.
                             if (i >= 20 && !waited.exchange(true)) {
                               for (int k = 0; k < 500 && !thrown; ++k)
                                 std::this_thread::sleep_for(std::chrono::milliseconds(10));
                               std::this_thread::sleep_for(std::chrono::milliseconds(50));
                             }
                           }),
               std::runtime_error);
  EXPECT_LT(ran.load(), 100000u);
  // The team is usable afterwards.
  std::atomic<size_t> after{0};
  ParallelFor(100, 2, [&](size_t) { ++after; });
  EXPECT_EQ(after.load(), 100u);
}

TEST(Parallel, LoopInsideAParallelLoopRunsOnItsCallersThread) {
  EXPECT_FALSE(InsideParallelLoop());
  std::atomic<int> inner_elsewhere{0}, inside{0};
  ParallelFor(8, 2, [&](size_t) {
    inside += InsideParallelLoop() ? 1 : 0;
    const std::thread::id outer = std::this_thread::get_id();
    ParallelFor(100, 2, [&](size_t) {
      if (std::this_thread::get_id() != outer) ++inner_elsewhere;
    });
  });
  EXPECT_EQ(inside.load(), 8);
  EXPECT_EQ(inner_elsewhere.load(), 0);
  EXPECT_FALSE(InsideParallelLoop());
  // A loop asked to run on one thread does not take the inner loops' threads away.
  ParallelFor(1, 1, [&](size_t) { EXPECT_FALSE(InsideParallelLoop()); });
}

TEST(Parallel, RunOnThreadsRunsEachWorkerOnceOutsideLoops) {
  std::vector<std::atomic<int>> runs(3);
  RunOnThreads(3, [&](int t) { ++runs[static_cast<size_t>(t)]; });
  for (const auto& r : runs) EXPECT_EQ(r.load(), 1);
  EXPECT_EQ(ResolveThreads(3), 3);
  EXPECT_GE(ResolveThreads(0), 1);
}

TEST(Parallel, RangesSumInChunkOrderForAnyThreadCount) {
  const size_t n = 100000;
  auto sum_with = [&](int threads) {
    const auto parts = ParallelRanges(n, threads, 0.0, [](size_t begin, size_t end, double& acc) {
      for (size_t i = begin; i < end; ++i) acc += 1.0 / (1.0 + static_cast<double>(i));
    });
    double total = 0;
    for (double p : parts) total += p;
    return total;
  };
  const double one = sum_with(1);
  EXPECT_EQ(sum_with(2), one);  // bit for bit
  EXPECT_EQ(sum_with(5), one);
}

TEST(Parallel, ChangeDetectionIsTheSameForAnyThreadCount) {
  const testing::BoxWorld world = testing::MakeBoxWorld();
  const PointCloud original = testing::SampleBoxSurfaces(world.original, 0.3);
  ChangeDetectionParams params;
  ApplyFreeSpaceRule("confident", &params);
  params.threads = 1;
  const ChangeDetectionResult serial = DetectChanges(world.keyframes, original, params);
  params.threads = 2;
  const ChangeDetectionResult parallel = DetectChanges(world.keyframes, original, params);
  ASSERT_FALSE(serial.changes.removed_points.empty());
  EXPECT_EQ(serial.global, parallel.global);
  EXPECT_EQ(serial.observed_prior, parallel.observed_prior);
  EXPECT_EQ(serial.changes.new_points, parallel.changes.new_points);
  EXPECT_EQ(serial.changes.removed_points, parallel.changes.removed_points);
  EXPECT_EQ(serial.observed.NumKnownLeaves(), parallel.observed.NumKnownLeaves());
}

}  // namespace
}  // namespace mapdelta
