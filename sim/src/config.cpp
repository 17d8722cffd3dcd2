#include "mapdelta/sim/config.hpp"

#include <cmath>

#include "mapdelta/common/error.hpp"

namespace mapdelta::sim {

NoiseParams NoiseFor(NoiseLevel level) {
  NoiseParams p;
  if (level == NoiseLevel::kSmall) {
    p = {4.0e-4, 3.0e-3, 4.0e-5, 3.0e-4, 0.02};
  } else if (level == NoiseLevel::kBig) {
    p = {4.0e-3, 3.0e-2, 4.0e-4, 3.0e-3, 0.04};
  } else if (level == NoiseLevel::kEuroc) {
    p = {1.6968e-4, 2.0e-3, 1.9393e-5, 3.0e-3, 0.02};
  }
  return p;
}

const char* ToString(NoiseLevel level) {
  switch (level) {
    case NoiseLevel::kNone:
      return "none";
    case NoiseLevel::kSmall:
      return "small";
    case NoiseLevel::kBig:
      return "big";
    case NoiseLevel::kEuroc:
      return "euroc";
  }
  return "?";
}

bool ParseNoiseLevel(const std::string& text, NoiseLevel* level) {
  if (text == "none")
    *level = NoiseLevel::kNone;
  else if (text == "small")
    *level = NoiseLevel::kSmall;
  else if (text == "big")
    *level = NoiseLevel::kBig;
  else if (text == "euroc")
    *level = NoiseLevel::kEuroc;
  else
    return false;
  return true;
}

SimConfig PresetConfig(const std::string& name) {
  SimConfig c;
  if (name == "tiny") return c;  // the struct's defaults are the tiny preset
  if (name == "paper") {
    c.preset = "paper";
    c.extent_x = c.extent_y = 250.0;
    c.max_height = 40.0;
    c.block_size = 36.0;
    c.street_width = 14.0;
    c.small_objects = 80;
    c.width = 800;
    c.height = 450;
    c.fx = c.fy = 400.0;
    c.cx = 400.0;
    c.cy = 225.0;
    c.cam_rate_hz = 30.0;
    c.length_m = 700.0;
    c.duration_s = 170.0;
    c.write_depth = false;
    c.sequences = {"S1_01", "S1_02", "S2_01", "S2_02", "S1_mirror", "S1_dark"};
    return c;
  }
  if (name == "euroc") {
    // A short flight with EuRoC MH_01's sensors (for the VIO's real-EuRoC path): a small city
    // (3x3 blocks) keeps the scene and clouds cheap; 752x480 at 20 Hz dominates the cost.
    c.preset = "euroc";
    c.rig = "euroc";
    c.noise = NoiseLevel::kEuroc;
    c.extent_x = c.extent_y = 90.0;
    c.small_objects = 12;
    c.width = 752;
    c.height = 480;
    c.fx = 458.654;
    c.fy = 457.296;
    c.cx = 367.215;
    c.cy = 248.375;
    c.baseline = 0.110;  // |t| of EuRoC's T_cam0_cam1, for info.json only
    c.cam_rate_hz = 20.0;
    c.imu_rate_hz = 200.0;
    c.length_m = 36.0;
    c.duration_s = 12.0;
    c.write_depth = false;
    c.cloud_leaf = 0.5;
    c.sequences = {"S1_01"};
    return c;
  }
  throw Error(ErrorCode::kInvalidArgument,
              "unknown preset '" + name + "' (expected tiny, paper or euroc)");
}

void Validate(const SimConfig& c) {
  std::string bad;
  auto check = [&](bool ok, const char* what) {
    if (!ok) bad += std::string(bad.empty() ? "" : "; ") + what;
  };
  auto pos = [](double v) { return std::isfinite(v) && v > 0; };
  check(pos(c.extent_x) && pos(c.extent_y), "extent_x/extent_y must be > 0");
  check(pos(c.block_size) && pos(c.street_width), "block_size/street_width must be > 0");
  check(c.extent_x >= c.block_size + 2 * c.street_width &&
            c.extent_y >= c.block_size + 2 * c.street_width,
        "extent must hold at least one block with streets around it");
  check(pos(c.min_height) && c.max_height >= c.min_height, "need 0 < min_height <= max_height");
  check(c.small_objects >= 0, "small_objects must be >= 0");
  check(pos(c.cloud_leaf), "cloud_leaf must be > 0");
  check(c.width >= 16 && c.height >= 16 && c.width <= 8192 && c.height <= 8192,
        "width/height must be in [16, 8192]");
  check(pos(c.fx) && pos(c.fy), "fx/fy must be > 0");
  check(std::isfinite(c.cx) && std::isfinite(c.cy), "cx/cy must be finite");
  check(pos(c.baseline), "baseline must be > 0");
  check(pos(c.cam_rate_hz) && c.cam_rate_hz <= 1000, "cam_rate_hz must be in (0, 1000]");
  check(pos(c.imu_rate_hz) && c.imu_rate_hz <= 10000, "imu_rate_hz must be in (0, 10000]");
  check(pos(c.length_m) && pos(c.duration_s), "length_m/duration_s must be > 0");
  check(c.length_m / c.duration_s <= 30.0, "length_m/duration_s gives a speed above 30 m/s");
  check(pos(c.height_01) && pos(c.height_02), "height_01/height_02 must be > 0");
  check(pos(c.spline_spacing), "spline_spacing must be > 0");
  check(c.threads >= 0, "threads must be >= 0");
  check(c.rig == "ideal" || c.rig == "euroc", "rig must be ideal or euroc");
  check(!c.sequences.empty(), "sequences must not be empty");
  for (const auto& s : c.sequences) {
    const bool known = s == "S1_01" || s == "S1_02" || s == "S2_01" || s == "S2_02" ||
                       s == "S1_mirror" || s == "S1_dark";
    if (!known)
      check(false,
            ("unknown sequence '" + s + "' (S1_01 S1_02 S2_01 S2_02 S1_mirror S1_dark)").c_str());
  }
  if (!bad.empty()) throw Error(ErrorCode::kInvalidArgument, "invalid sim config: " + bad);
}

}  // namespace mapdelta::sim
