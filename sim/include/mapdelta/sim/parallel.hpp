#pragma once
// The simulator's loops: independent jobs over an index range on common's parallel layer
// (mapdelta/common/parallel.hpp), with progress. Used by the generator and by renoise.
#include <cstddef>
#include <functional>
#include <string>

namespace mapdelta::sim {

// Stage name, units done, units total; called at most every 100 ms by the worker that has just
// finished a job (one call at a time), and once at the end.
using ProgressFn = std::function<void(const std::string& stage, size_t done, size_t total)>;

// Runs job(i) for i in [0, n) on `threads` threads, the caller included. Results must not
// depend on which thread runs which i. The first exception stops the remaining jobs and is
// rethrown.
void ParallelFor(size_t n, int threads, const std::string& stage, const ProgressFn& progress,
                 const std::function<void(size_t)>& job);

}  // namespace mapdelta::sim
