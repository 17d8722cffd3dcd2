#pragma once
// Gives the memory malloc keeps after frees back to the system. A commit job allocates its
// session's clouds and every decoded session octree of its tiles (the job's ObservedCache) on
// the worker and its team threads, and frees them at the end; glibc keeps those pages in its
// arenas (several per process, one per busy thread at most 8 x cores), so the server's RSS
// grew with every commit while the data it held stayed at 10-20 MiB (docs/reliability.md, load
// runs 3-5). Called after each job: malloc_trim walks every arena and releases their free
// pages (madvise), a few milliseconds.
#include <cstdint>

namespace mapdelta::server {

// Returns false where the C library has no such call (not glibc): nothing done.
bool ReturnFreedHeapToSystem();

}  // namespace mapdelta::server
