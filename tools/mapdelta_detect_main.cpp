// mapdelta-detect: thin entry point; the pipeline lives in src/detect_command.cpp.
#include <iostream>

#include "mapdelta/common/cli.hpp"
#include "mapdelta/tools/commands.hpp"

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  return mapdelta::cli::RunMain("mapdelta-detect",
                                [&] { return mapdelta::tools::RunDetect(args, std::cout); });
}
