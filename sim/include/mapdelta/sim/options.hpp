#pragma once
// Command-line parsing for mapdelta-sim: --preset first, then any SimConfig field as
// --<field> VALUE. Unknown options and bad values are errors listed all at once.
#include <string>
#include <vector>

#include "mapdelta/sim/config.hpp"

namespace mapdelta::sim {

struct CliArgs {
  SimConfig config;
  std::string out_dir;
  std::string log_level = "info";
  bool help = false;
  bool quiet = false;  // no progress bar
};

// Throws Error(kInvalidArgument) listing every problem.
CliArgs ParseArgs(const std::vector<std::string>& args);
// The --help text, with each option's default under `preset`.
std::string HelpText(const std::string& preset = "tiny");

}  // namespace mapdelta::sim
