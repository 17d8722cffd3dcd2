// mapdelta-detect: thin entry point; the pipeline lives in src/detect_command.cpp.
#include <iostream>

#include "mapdelta/tools/commands.hpp"
#include "src/main_support.hpp"

int main(int argc, char** argv) {
  using namespace mapdelta::tools;
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || WantsHelp(args)) {
    (args.empty() ? std::cerr : std::cout) << kDetectUsage;  // no arguments is a usage error
    return args.empty() ? 2 : 0;
  }
  return RunMain("mapdelta-detect", [&] { return RunDetect(args, std::cout); });
}
