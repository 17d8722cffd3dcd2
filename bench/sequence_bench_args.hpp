#pragma once
// Command line shared by the benchmarks that run on an EuRoC-layout sequence (bench_vio,
// bench_client): --sequence DIR, --seconds S, --no-baseline, and --prior CLOUD where asked.
#include <cstdlib>
#include <iostream>
#include <optional>
#include <string>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/euroc.hpp"

namespace mapdelta::bench {

struct SequenceBenchArgs {
  std::string sequence;
  double seconds = 0;  // prefix to run; 0: the caller's default
  bool baseline = true;
  std::optional<std::string> prior;
};

// nullopt: go on with `args`; otherwise the exit code (0 after --help, 2 on a bad command
// line, with the message and the usage on stderr).
inline std::optional<int> ParseSequenceBenchArgs(int argc, char** argv, const char* name,
                                                 const char* usage, bool accepts_prior,
                                                 SequenceBenchArgs* args) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << usage;
      return 0;
    } else if (a == "--sequence" && i + 1 < argc) {
      args->sequence = argv[++i];
    } else if (accepts_prior && a == "--prior" && i + 1 < argc) {
      args->prior = argv[++i];
    } else if (a == "--seconds" && i + 1 < argc) {
      char* end = nullptr;
      args->seconds = std::strtod(argv[++i], &end);
      if (*end != '\0' || !(args->seconds > 0)) {
        std::cerr << name << ": --seconds expects a positive number\n";
        return 2;
      }
    } else if (a == "--no-baseline") {
      args->baseline = false;
    } else {
      std::cerr << name << ": unknown or incomplete option " << a << "\n" << usage;
      return 2;
    }
  }
  if (args->sequence.empty()) {
    std::cerr << name << ": --sequence is required\n" << usage;
    return 2;
  }
  return std::nullopt;
}

// Camera rate of the sequence's stereo frames, Hz. Throws Error for fewer than 2 frames.
inline double StereoFrameRate(const EurocSequence& seq, const std::string& dir) {
  const auto frames = seq.StereoFrames();
  if (frames.size() < 2) throw Error(ErrorCode::kInvalidArgument, dir + ": fewer than 2 frames");
  return 1e9 * static_cast<double>(frames.size() - 1) /
         static_cast<double>(frames.back().t_ns - frames.front().t_ns);
}

}  // namespace mapdelta::bench
