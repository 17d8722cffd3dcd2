// mapdelta-eval: thin entry point; the commands live in src/eval_commands.cpp.
#include <iostream>

#include "mapdelta/tools/commands.hpp"
#include "src/main_support.hpp"

int main(int argc, char** argv) {
  using namespace mapdelta::tools;
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || WantsHelp(args)) {
    (args.empty() ? std::cerr : std::cout) << kEvalUsage;  // no arguments is a usage error
    return args.empty() ? 2 : 0;
  }
  const std::vector<std::string> rest(args.begin() + 1, args.end());
  return RunMain("mapdelta-eval", [&] {
    if (args[0] == "ate") return RunEvalAte(rest, std::cout);
    if (args[0] == "changes") return RunEvalChanges(rest, std::cout);
    throw mapdelta::Error(mapdelta::ErrorCode::kInvalidArgument,
                          "unknown command '" + args[0] + "' (expected ate or changes; see --help)");
  });
}
