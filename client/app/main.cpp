// mapdelta-client: the vehicle pipeline's command line. Subcommands live in app/cmd_*.cpp.
#include <cstdio>
#include <cstring>
#include <map>
#include <string>

#include "commands.hpp"
#include "mapdelta/common/cli.hpp"

namespace {

void PrintUsage(std::FILE* to) {
  std::fprintf(
      to,
      "usage: mapdelta-client <command> [options]\n"
      "commands:\n"
      "  disparity LEFT RIGHT OUT [--num-disparities N] [--config FILE]\n"
      "            one pair's SGBM disparity with the production settings (.pfm/.tif)\n"
      "  run --sequence DIR --odometry vio|FILE (--prior FILE | --server URL --token T) --out DIR\n"
      "            the whole pipeline over a recorded sequence\n"
      "  upload DIR --server URL --token T\n"
      "            upload a keyframe folder written in offline mode\n"
      "  config [--config FILE]   print the effective configuration\n"
      "  drift GT OUT [...]       drifting odometry from ground truth (test fixture)\n"
      "  depth-eval KEYFRAMES SEQUENCE  keyframe depth vs the sequence's depth0 ground truth\n"
      "Run 'mapdelta-client <command> --help' for a command's options.\n"
      "%s\n",
      mapdelta::cli::kExitCodesFooter);
}

}  // namespace

int main(int argc, char** argv) {
  namespace cli = mapdelta::cli;
  namespace app = mapdelta::client::app;
  if (argc < 2 || std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0) {
    PrintUsage(argc < 2 ? stderr : stdout);
    return argc < 2 ? cli::kExitUsage : cli::kExitOk;
  }
  const std::string command = argv[1];
  const std::map<std::string, int (*)(int, char**)> commands = {
      {"disparity", app::RunDisparity}, {"config", app::RunConfig},
      {"run", app::RunPipelineCommand}, {"upload", app::RunUpload},
      {"drift", app::RunDrift},         {"depth-eval", app::RunDepthEval}};
  const auto it = commands.find(command);
  if (it == commands.end()) {
    std::fprintf(stderr,
                 "mapdelta-client: error: unknown command '%s' (see 'mapdelta-client --help')\n",
                 command.c_str());
    return cli::kExitUsage;
  }
  return cli::RunMain("mapdelta-client " + command, [&] { return it->second(argc - 1, argv + 1); });
}
