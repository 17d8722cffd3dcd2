#pragma once
// The tools' commands as library functions: main() only converts argv and exceptions.
// Each returns the process exit code, writes results to `out` and progress to the log, and
// throws Error(kInvalidArgument) for usage errors (cli::RunMain turns that into exit code 2).
#include <ostream>
#include <string>
#include <vector>

namespace mapdelta::tools {

extern const char* const kEvalUsage;  // the command list; each command has its own --help

// mapdelta-eval ate REF EST [--align se3|sim3|none] [--max-dt S] [--json FILE]
int RunEvalAte(const std::vector<std::string>& args, std::ostream& out);
// mapdelta-eval changes --original .. --changed .. --new .. --removed .. --global .. --observed ..
int RunEvalChanges(const std::vector<std::string>& args, std::ostream& out);
// mapdelta-eval removed-breakdown --original .. --changed .. --removed .. --global .. --observed ..
//   --keyframes DIR [--gt-depth DIR] [--removed-at-gt-poses CLOUD]: where false removals come from
int RunEvalRemovedBreakdown(const std::vector<std::string>& args, std::ostream& out);
// mapdelta-detect --prior CLOUD --keyframes DIR --out DIR [...]
int RunDetect(const std::vector<std::string>& args, std::ostream& out);

}  // namespace mapdelta::tools
