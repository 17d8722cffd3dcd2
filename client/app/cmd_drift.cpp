// mapdelta-client drift: drifting odometry from ground truth (a fixture for fusion runs).
#include <cstdint>
#include <iostream>
#include <string>

#include "commands.hpp"
#include "mapdelta/client/odometry_drift.hpp"
#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/trajectory_io.hpp"

namespace mapdelta::client::app {

int RunDrift(int argc, char** argv) {
  DriftParams p;
  std::string gt_path, out_path;
  uint64_t seed = p.seed;
  cli::Parser cli("mapdelta-client drift",
                  "Drifting odometry from ground truth (a fixture for fusion runs).");
  cli.Positional("GT", &gt_path, "ground truth, TUM or EuRoC CSV")
      .Positional("OUT", &out_path, "TUM odometry written here (identity at the first pose)")
      .Option("yaw-deg-per-m", &p.yaw_deg_per_m, "yaw drift [deg/m]")
      .Option("pitch-deg-per-m", &p.pitch_deg_per_m, "pitch drift [deg/m]")
      .Option("scale-error", &p.scale_error, "relative scale error")
      .Option("rot-noise", &p.rot_noise_deg_per_sqrt_m, "rotation random walk [deg/sqrt(m)]")
      .Option("trans-noise", &p.trans_noise_per_sqrt_m, "translation random walk [1/sqrt(m)]")
      .Option("seed", &seed, "random seed (32 bits)")
      .Footer(cli::kExitCodesFooter);
  if (!cli.Parse(argc, argv, std::cout)) return cli::kExitOk;
  if (seed > UINT32_MAX)
    cli::FailUsage(cli.program(), "--seed: expected a 32-bit integer, got " + std::to_string(seed));
  p.seed = static_cast<uint32_t>(seed);
  WriteTumTrajectory(out_path, AddDrift(ReadTrajectory(gt_path), p));
  return 0;
}
}  // namespace mapdelta::client::app
