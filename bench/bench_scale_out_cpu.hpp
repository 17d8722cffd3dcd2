#pragma once
// CPU seconds of processes from /proc, for bench_scale_out's account of where the ingest CPU
// goes (server processes, PostgreSQL, the uploaders) and how many of the machine's cores it
// keeps busy. Linux only, as the benchmark is.
#include <sys/resource.h>
#include <sys/types.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace mapdelta::bench {

struct ProcStat {
  pid_t ppid = 0;
  double cpu_s = 0;  // user + system
};

// /proc/PID/stat of a live process; cpu_s = 0 for a process that is gone.
inline ProcStat ReadProcStat(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  ProcStat s;
  if (!std::getline(in, line)) return s;
  // The command name (field 2) is in parentheses and may hold spaces: parse after the last ')'.
  std::istringstream rest(line.substr(line.rfind(')') + 2));
  std::vector<std::string> f;
  for (std::string w; rest >> w;) f.push_back(w);
  if (f.size() < 13) return s;  // fields 3.. : state ppid ... utime(14) stime(15)
  s.ppid = static_cast<pid_t>(std::stol(f[1]));
  s.cpu_s = (std::stod(f[11]) + std::stod(f[12])) / static_cast<double>(sysconf(_SC_CLK_TCK));
  return s;
}

// CPU seconds of pid and of its live children (PostgreSQL's backends are the postmaster's).
inline double CpuWithChildren(pid_t pid) {
  double total = ReadProcStat(pid).cpu_s;
  for (const auto& entry : std::filesystem::directory_iterator("/proc")) {
    const std::string name = entry.path().filename();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    const ProcStat s = ReadProcStat(static_cast<pid_t>(std::stol(name)));
    if (s.ppid == pid) total += s.cpu_s;
  }
  return total;
}

// CPU seconds of this process (all its threads: the uploaders).
inline double OwnCpu() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + (u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

}  // namespace mapdelta::bench
