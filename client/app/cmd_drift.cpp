// mapdelta-client drift: drifting odometry from ground truth (a fixture for fusion runs).
#include <cstdio>

#include "args.hpp"
#include "commands.hpp"
#include "mapdelta/client/odometry_drift.hpp"
#include "mapdelta/common/trajectory_io.hpp"

namespace mapdelta::client::app {

int RunDrift(int argc, char** argv) {
  const char* usage =
      "usage: mapdelta-client drift GT OUT.txt [--yaw-deg-per-m X] [--pitch-deg-per-m X]\n"
      "                             [--scale-error X] [--rot-noise X] [--trans-noise X] [--seed N]\n"
      "  GT: TUM or EuRoC CSV ground truth; OUT: TUM odometry (identity at the first pose)\n";
  Args args;
  try {
    args = ParseArgs(argc, argv, {"yaw-deg-per-m", "pitch-deg-per-m", "scale-error", "rot-noise", "trans-noise", "seed"});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n%s", e.what(), usage);
    return 2;
  }
  if (args.help || args.positional.size() != 2) {
    std::fprintf(stderr, "%s", usage);
    return args.help ? 0 : 2;
  }
  DriftParams p;
  try {
    p.yaw_deg_per_m = std::stod(args.Get("yaw-deg-per-m", "0.05"));
    p.pitch_deg_per_m = std::stod(args.Get("pitch-deg-per-m", "0"));
    p.scale_error = std::stod(args.Get("scale-error", "0.01"));
    p.rot_noise_deg_per_sqrt_m = std::stod(args.Get("rot-noise", "0"));
    p.trans_noise_per_sqrt_m = std::stod(args.Get("trans-noise", "0"));
    p.seed = static_cast<uint32_t>(std::stoul(args.Get("seed", "1")));
  } catch (const std::exception&) {
    std::fprintf(stderr, "drift: option values must be numbers\n%s", usage);
    return 2;
  }
  WriteTumTrajectory(args.positional[1], AddDrift(ReadTrajectory(args.positional[0]), p));
  return 0;
}

}  // namespace mapdelta::client::app
