// mapdelta-eval: thin entry point; the commands live in src/eval_commands.cpp.
#include <iostream>

#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/tools/commands.hpp"

int main(int argc, char** argv) {
  using namespace mapdelta;
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (!args.empty() && (args[0] == "--help" || args[0] == "-h")) {
    std::cout << tools::kEvalUsage;
    return cli::kExitOk;
  }
  return cli::RunMain("mapdelta-eval", [&] {
    const std::vector<std::string> rest(args.begin() + std::min<size_t>(args.size(), 1),
                                        args.end());
    if (!args.empty() && args[0] == "ate") return tools::RunEvalAte(rest, std::cout);
    if (!args.empty() && args[0] == "changes") return tools::RunEvalChanges(rest, std::cout);
    if (!args.empty() && args[0] == "removed-breakdown")
      return tools::RunEvalRemovedBreakdown(rest, std::cout);
    cli::FailUsage("mapdelta-eval", args.empty()
                                        ? "missing COMMAND (ate, changes or removed-breakdown)"
                                        : "unknown command '" + args[0] +
                                              "' (expected ate, changes or removed-breakdown)");
  });
}
