#pragma once
// Command-line parsing for mapdelta-sim (common's cli::Parser): --preset, then any SimConfig
// field as --<field> VALUE on top of it. Bad values are errors listed all at once.
#include <functional>
#include <string>
#include <vector>

#include "mapdelta/common/cli.hpp"
#include "mapdelta/sim/config.hpp"

namespace mapdelta::sim {

struct CliArgs {
  SimConfig config;
  std::string out_dir;
  std::string log_level = "info";
  bool help = false;
  bool quiet = false;  // no progress bar
};

// A program that takes mapdelta-sim's options and some of its own (mapdelta-sim-preview).
struct CliExtension {
  std::string program;
  std::string description;
  std::function<void(cli::Parser*)> declare;  // adds the program's own options
};

// Throws Error(kInvalidArgument) naming an unknown option, or listing every bad value.
CliArgs ParseArgs(const std::vector<std::string>& args, const CliExtension* extension = nullptr);
// The --help text, with each option's default under the tiny and paper presets.
std::string HelpText(const CliExtension* extension = nullptr);

}  // namespace mapdelta::sim
