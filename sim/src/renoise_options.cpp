// Command line of `mapdelta-sim renoise` (see renoise.hpp).
#include <sstream>

#include "mapdelta/common/cli.hpp"
#include "mapdelta/sim/renoise.hpp"

namespace mapdelta::sim {

namespace {

constexpr const char* kProgram = "mapdelta-sim renoise";

void DeclareOptions(cli::Parser* cli, RenoiseOptions* o, std::string* noise, std::string* sequences,
                    bool* quiet) {
  cli->Option("from", &o->from_dir, "dataset written by mapdelta-sim with --noise none", "CLEAN")
      .Option("out", &o->out_dir, "new dataset (may be the same path as a previous renoise output)",
              "DIR")
      .Option("noise", noise, "sensor noise preset")
      .Choices("noise", {"none", "small", "big"})
      .Option("seed", &o->seed, "noise seed; the city and trajectories keep CLEAN's seed")
      .Option("sequences", sequences, "comma-separated sequences (default: all in CLEAN/sequences)",
              "A,B")
      .Option("threads", &o->threads, "worker threads (0: all cores)")
      .Flag("quiet", quiet, "no progress")
      .Require({"from", "out"})
      .Footer(cli::kExitCodesFooter);
}

constexpr const char* kDescription =
    "New sensor noise on a dataset rendered with --noise none, without rendering again: image "
    "noise on\n"
    "the stored clean images, IMU noise on the clean IMU samples, ground truth biases rewritten, "
    "scenes\n"
    "and depth0 hard-linked. With --seed equal to the clean dataset's seed the output is "
    "byte-identical\n"
    "to 'mapdelta-sim --noise NAME' directly.";

}  // namespace

std::string RenoiseHelpText() {
  RenoiseOptions o;
  std::string noise = "small", sequences;
  bool quiet = false;
  cli::Parser cli(kProgram, kDescription);
  DeclareOptions(&cli, &o, &noise, &sequences, &quiet);
  return cli.Help();
}

RenoiseOptions ParseRenoiseArgs(const std::vector<std::string>& args, bool* help, bool* quiet) {
  RenoiseOptions o;
  std::string noise = "small", sequences;
  *quiet = false;
  cli::Parser cli(kProgram, kDescription);
  DeclareOptions(&cli, &o, &noise, &sequences, quiet);
  std::ostringstream help_text;  // main prints RenoiseHelpText()
  *help = !cli.Parse(args, help_text);
  if (*help) return o;
  ParseNoiseLevel(noise, &o.noise);  // one of the choices above
  if (o.threads < 0 || o.threads > 1024) {
    cli::FailUsage(kProgram, "--threads: expected 0..1024, got " + std::to_string(o.threads));
  }
  if (cli.Given("sequences")) {
    std::stringstream ss(sequences);
    for (std::string item; std::getline(ss, item, ',');) {
      if (!item.empty()) o.sequences.push_back(item);
    }
    if (o.sequences.empty())
      cli::FailUsage(kProgram,
                     "--sequences: expected a comma-separated list, got '" + sequences + "'");
  }
  return o;
}

}  // namespace mapdelta::sim
