#pragma once
// Generates a whole dataset (docs/conventions.md): scenes original/S1/S2 with GT clouds and
// objects.json, then every configured sequence (stereo images, optional depth, IMU, GT).
#include <cstdint>
#include <functional>
#include <string>

#include "mapdelta/sim/config.hpp"
#include "mapdelta/sim/parallel.hpp"
#include "mapdelta/sim/scene.hpp"
#include "mapdelta/sim/trajectory.hpp"

namespace mapdelta::sim {

struct Scenes {
  Scene original;
  ChangedScene s1, s2;
};
Scenes BuildScenes(const SimConfig& config);

// The description of one sequence: which scene, which variant, its trajectory.
struct SequencePlan {
  std::string name;  // e.g. "S1_01"
  const ChangedScene* scene = nullptr;
  std::string variant;  // "normal", "mirror" or "dark"
  double height = 0;
  SplineTrajectory trajectory;
  double duration_s = 0;  // <= trajectory.duration()
  double length_m = 0;    // path length over [0, duration_s]
};
SequencePlan PlanSequence(const SimConfig& config, const Scenes& scenes, const std::string& name);
// The scene a sequence is rendered in: its changed scene plus the variant's mirrors or lighting.
Scene RenderScene(const SequencePlan& plan);

// Throws Error on invalid config or I/O failure. Output is a function of config alone
// (byte-identical for the same config, whatever the thread count).
void GenerateDataset(const SimConfig& config, const std::string& out_dir,
                     const ProgressFn& progress);
// The key of a sequence's sensor noise (image noise of frame k, camera c: HashCombine(key,
// 2k+c); IMU stream: AddImuNoise's seed). `seed` is the noise seed: the config's seed for
// the generator, --seed for renoise.
uint64_t SequenceNoiseKey(uint64_t seed, const std::string& sequence);
// One sequence only (the scenes' files are not written); frames [0, max_frames) if max_frames > 0.
void GenerateSequence(const SimConfig& config, const Scenes& scenes, const std::string& name,
                      const std::string& out_dir, const ProgressFn& progress,
                      size_t max_frames = 0);

}  // namespace mapdelta::sim
