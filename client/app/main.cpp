// mapdelta-client: the vehicle pipeline's command line. Subcommands live in app/cmd_*.cpp.
#include <cstdio>
#include <cstring>
#include <string>

#include "commands.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"

namespace {

void PrintUsage() {
  std::fprintf(stderr,
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
               "Run 'mapdelta-client <command> --help' for a command's options.\n");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0) {
    PrintUsage();
    return argc < 2 ? 2 : 0;
  }
  const std::string command = argv[1];
  try {
    if (command == "disparity") return mapdelta::client::app::RunDisparity(argc - 1, argv + 1);
    if (command == "config") return mapdelta::client::app::RunConfig(argc - 1, argv + 1);
    if (command == "run") return mapdelta::client::app::RunPipeline(argc - 1, argv + 1);
    if (command == "upload") return mapdelta::client::app::RunUpload(argc - 1, argv + 1);
    if (command == "drift") return mapdelta::client::app::RunDrift(argc - 1, argv + 1);
    if (command == "depth-eval") return mapdelta::client::app::RunDepthEval(argc - 1, argv + 1);
  } catch (const mapdelta::Error& e) {
    std::fprintf(stderr, "mapdelta-client %s: error (%s): %s\n", command.c_str(),
                 std::string(mapdelta::ToString(e.code())).c_str(), e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mapdelta-client %s: error: %s\n", command.c_str(), e.what());
    return 1;
  }
  std::fprintf(stderr, "mapdelta-client: unknown command '%s'\n", command.c_str());
  PrintUsage();
  return 2;
}
