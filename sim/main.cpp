// mapdelta-sim: thin CLI over mapdelta_sim (options.hpp, generator.hpp).
#include <unistd.h>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/sim/generator.hpp"
#include "mapdelta/sim/options.hpp"
#include "mapdelta/sim/renoise.hpp"

namespace {

// One-line progress bar on stderr, redrawn in place on a terminal; one line per 10% otherwise.
void DrawProgress(const std::string& stage, size_t done, size_t total) {
  if (!isatty(STDERR_FILENO)) {
    std::fprintf(stderr, "%s: %zu/%zu\n", stage.c_str(), done, total);
    return;
  }
  const int width = 30;
  const double f = total ? static_cast<double>(done) / static_cast<double>(total) : 1.0;
  const int filled = static_cast<int>(f * width);
  std::fprintf(stderr, "\r%-20s [%s%s] %5.1f%% (%zu/%zu)", stage.c_str(),
               std::string(static_cast<size_t>(filled), '#').c_str(),
               std::string(static_cast<size_t>(width - filled), '.').c_str(), 100.0 * f, done,
               total);
  if (done >= total) std::fprintf(stderr, "\n");
  std::fflush(stderr);
}

}  // namespace

// `mapdelta-sim renoise ...`: new noise on a clean dataset (renoise.hpp).
int RunRenoise(const std::vector<std::string>& args) {
  using namespace mapdelta;
  bool help = false, quiet = false;
  const sim::RenoiseOptions options = sim::ParseRenoiseArgs(args, &help, &quiet);
  if (help) {
    std::cout << sim::RenoiseHelpText();
    return cli::kExitOk;
  }
  const auto start = std::chrono::steady_clock::now();
  long last_step = -1;
  std::string last_stage;
  auto progress = [&](const std::string& stage, size_t done, size_t total) {
    const long steps = isatty(STDERR_FILENO) ? 200 : 10;
    const long step = total ? static_cast<long>(done * static_cast<size_t>(steps) / total) : steps;
    if (quiet || (stage == last_stage && step == last_step)) return;
    last_stage = stage;
    last_step = step;
    DrawProgress(stage, done, total);
  };
  sim::RenoiseDataset(options, progress);
  const double secs =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  MD_LOG(kInfo, "renoised dataset written to " << options.out_dir << " in " << secs << " s");
  return cli::kExitOk;
}

// `mapdelta-sim --preset ... --out DIR`: a whole dataset (generator.hpp).
int RunGenerate(const std::vector<std::string>& args) {
  using namespace mapdelta;
  const sim::CliArgs parsed = sim::ParseArgs(args);
  if (parsed.help) {
    std::cout << sim::HelpText();
    return cli::kExitOk;
  }
  log::Level level = log::Level::kInfo;
  log::ParseLevel(parsed.log_level, &level);  // one of the parser's choices
  log::SetLevel(level);
  const auto start = std::chrono::steady_clock::now();
  std::string last_stage;
  long last_step = -1;
  const long steps = isatty(STDERR_FILENO) ? 200 : 10;  // redraws per stage
  auto progress = [&](const std::string& stage, size_t done, size_t total) {
    const long step = total ? static_cast<long>(done * static_cast<size_t>(steps) / total) : steps;
    if (parsed.quiet || (stage == last_stage && step == last_step)) return;
    last_stage = stage;
    last_step = step;
    DrawProgress(stage, done, total);
  };
  sim::GenerateDataset(parsed.config, parsed.out_dir, progress);
  const double secs =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  MD_LOG(kInfo, "dataset written to " << parsed.out_dir << " in " << secs << " s");
  return cli::kExitOk;
}

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (!args.empty() && args[0] == "renoise") {
    return mapdelta::cli::RunMain("mapdelta-sim renoise", [&] {
      return RunRenoise({args.begin() + 1, args.end()});
    });
  }
  return mapdelta::cli::RunMain("mapdelta-sim", [&] { return RunGenerate(args); });
}
