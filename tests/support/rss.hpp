#pragma once
// A process's resident set size (VmRSS in /proc/PID/status), for the memory tests and the load
// bench's sampler.
#include <sys/types.h>

#include <cstdint>
#include <fstream>
#include <string>

namespace mapdelta::testing {

// VmRSS of process pid in KiB; -1 when it cannot be read (the process is gone).
inline int64_t ReadRssKib(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string key;
  while (in >> key) {
    if (key == "VmRSS:") {
      int64_t kib = 0;
      in >> kib;
      return kib;
    }
    in.ignore(4096, '\n');
  }
  return -1;
}

}  // namespace mapdelta::testing
