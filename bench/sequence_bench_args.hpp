#pragma once
// Command line shared by the benchmarks that run on an EuRoC-layout sequence (bench_vio,
// bench_client): --sequence DIR, --seconds S, --no-baseline, and --prior CLOUD where asked.
#include <iostream>
#include <optional>
#include <string>

#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/euroc.hpp"

namespace mapdelta::bench {

struct SequenceBenchArgs {
  std::string sequence;
  double seconds = 0;  // prefix to run; 0: all of it
  bool baseline = true;
  std::optional<std::string> prior;
};

// nullopt: go on with `args` (its values on entry are the defaults); otherwise the exit code
// (0 after --help, 2 on a bad command line, with the message on stderr). `description`: the
// benchmark's --help paragraph.
inline std::optional<int> ParseSequenceBenchArgs(int argc, char** argv, const char* name,
                                                 const char* description, bool accepts_prior,
                                                 SequenceBenchArgs* args) {
  cli::Parser cli(name, description);
  std::string prior;
  bool no_baseline = false;
  cli.Option("sequence", &args->sequence,
             "EuRoC-layout sequence (e.g. DATA/sequences/S1_01 of the paper preset)", "DIR")
      .Option("seconds", &args->seconds, "prefix of the sequence to run [s] (0: all of it)", "S")
      .Flag("no-baseline", &no_baseline, "only the shipped structure, no baseline run")
      .Require({"sequence"});
  if (accepts_prior) {
    cli.Option("prior", &prior,
               "prior map (PCD/PLY) for registration and fusion; default: the dataset's "
               "scenes/original/cloud.pcd if there, else none",
               "CLOUD");
  }
  if (const auto exit_code = cli::ParseMain(cli, argc, argv, [&] {
        if (!(args->seconds >= 0))
          cli::FailUsage(name, "--seconds: expected a non-negative number");
      })) {
    return exit_code;
  }
  args->baseline = !no_baseline;
  if (accepts_prior && cli.Given("prior")) args->prior = prior;
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
