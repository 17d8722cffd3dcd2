#pragma once
// `mapdelta-sim renoise`: new sensor noise on an already rendered, noise-free dataset.
// Rendering dominates the simulator's time and trials of an experiment differ only in noise,
// so a trial is: render once with --noise none, then renoise per noise seed. The result is
// byte-identical to generating with that noise directly when the noise seed equals the
// dataset's seed (the generator adds the same noise functions to the same clean values:
// AddImageNoise on the 8-bit clean image, AddImuNoise on the clean CSV values).
#include <cstdint>
#include <string>
#include <vector>

#include "mapdelta/sim/config.hpp"
#include "mapdelta/sim/parallel.hpp"

namespace mapdelta::sim {

struct RenoiseOptions {
  std::string from_dir;  // dataset written with --noise none
  std::string out_dir;   // new dataset (scenes and depth are hard links if possible)
  NoiseLevel noise = NoiseLevel::kSmall;
  uint64_t seed = 1;                   // noise seed (info.json noise_seed; the city keeps its seed)
  std::vector<std::string> sequences;  // empty: every folder in FROM/sequences
  int threads = 0;                     // 0 = hardware concurrency
};

// Throws Error naming the file and problem (missing file, not noise-free, malformed CSV row).
void RenoiseDataset(const RenoiseOptions& options, const ProgressFn& progress);

// argv after "renoise" -> options; throws Error(kInvalidArgument) naming the option.
// Sets *help for --help, *quiet for --quiet.
RenoiseOptions ParseRenoiseArgs(const std::vector<std::string>& args, bool* help, bool* quiet);
std::string RenoiseHelpText();

}  // namespace mapdelta::sim
