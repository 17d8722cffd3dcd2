#pragma once
// The simulator's one thread pool idiom: independent jobs over an index range, progress
// reported from the calling thread. Used by the generator and by renoise.
#include <cstddef>
#include <functional>
#include <string>

namespace mapdelta::sim {

// Called from the generating thread: stage name, units done, units total.
using ProgressFn = std::function<void(const std::string& stage, size_t done, size_t total)>;

// Runs job(i) for i in [0, n) on `threads` workers (>= 1). Results must not depend on which
// worker runs which i. The first exception stops the remaining jobs and is rethrown.
void ParallelFor(size_t n, int threads, const std::string& stage, const ProgressFn& progress,
                 const std::function<void(size_t)>& job);

// `requested` if > 0, else the hardware concurrency (at least 1).
int ResolveThreads(int requested);

}  // namespace mapdelta::sim
