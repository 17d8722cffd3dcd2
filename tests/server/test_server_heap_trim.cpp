// ReturnFreedHeapToSystem (server/src/heap_trim.hpp), called by the job worker after each job:
// memory a finished thread allocated in many small blocks and freed, with a few blocks kept
// (the pattern of a commit job's decoded octrees and clouds), stays in the process's resident
// set until trimmed; trimmed, it leaves. Measured on this process's VmRSS.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "heap_trim.hpp"
#include "support/rss.hpp"

namespace mapdelta::server {
namespace {

int64_t RssKib() { return mapdelta::testing::ReadRssKib(getpid()); }

TEST(HeapTrim, FreedBlocksOfAFinishedThreadLeaveTheResidentSet) {
#ifndef __GLIBC__
  GTEST_SKIP() << "malloc_trim is glibc's";
#endif
  constexpr int kBlocks = 100000, kBlockBytes = 1000;  // ~100 MB, below the mmap threshold
  std::vector<char*> kept;                             // every 64th block: one page in 16
  std::thread([&] {
    std::vector<char*> blocks;
    blocks.reserve(kBlocks);
    for (int i = 0; i < kBlocks; ++i) {
      char* b = static_cast<char*>(std::malloc(kBlockBytes));
      std::memset(b, 1, kBlockBytes);  // resident
      blocks.push_back(b);
    }
    for (int i = 0; i < kBlocks; ++i) {
      if (i % 64 == 0)
        kept.push_back(blocks[i]);
      else
        std::free(blocks[i]);
    }
  }).join();
  const int64_t before = RssKib();
  ASSERT_TRUE(ReturnFreedHeapToSystem());
  const int64_t after = RssKib();
  for (char* b : kept) std::free(b);
  std::printf("VmRSS %lld -> %lld KiB\n", static_cast<long long>(before),
              static_cast<long long>(after));
  EXPECT_LT(after, before - 50 * 1024) << "the ~94 MB freed stayed resident";
}

}  // namespace
}  // namespace mapdelta::server
