#pragma once
// Every knob of the simulator in one place, with units and the presets `tiny` and `paper`.
// The CLI exposes each field as --<name> (see options.hpp); presets only change defaults.
#include <cstdint>
#include <string>
#include <vector>

namespace mapdelta::sim {

// kEuroc: EuRoC MH_01's imu0/sensor.yaml densities (ADIS16448) with the small image noise.
enum class NoiseLevel { kNone, kSmall, kBig, kEuroc };

// Paper table (DESIGN.md): continuous-time densities and image sigma (fraction of full scale).
struct NoiseParams {
  double gyro_noise_density = 0.0;   // rad/s/sqrt(Hz)
  double accel_noise_density = 0.0;  // m/s^2/sqrt(Hz)
  double gyro_random_walk = 0.0;     // rad/s^2/sqrt(Hz)
  double accel_random_walk = 0.0;    // m/s^3/sqrt(Hz)
  double image_sigma = 0.0;          // gaussian sigma as a fraction of full intensity
};
NoiseParams NoiseFor(NoiseLevel level);
const char* ToString(NoiseLevel level);
bool ParseNoiseLevel(const std::string& text, NoiseLevel* level);

struct SimConfig {
  std::string preset = "tiny";
  uint64_t seed = 1;
  NoiseLevel noise = NoiseLevel::kNone;
  int threads = 0;  // 0 = hardware concurrency

  // Scene (metres). The city is a grid of blocks separated by streets.
  double extent_x = 120.0;
  double extent_y = 120.0;
  double max_height = 30.0;  // tallest building
  double min_height = 6.0;
  double block_size = 22.0;    // block edge between streets
  double street_width = 10.0;  // kerb to kerb incl. sidewalks
  int small_objects = 20;      // cars, trees, lamps, kiosks
  double cloud_leaf = 0.2;     // GT cloud voxel size after dense sampling

  // Sensor rig (sensor_rig.hpp): "ideal" = the camera fields below; "euroc" = EuRoC MH_01's
  // distorted, slightly non-parallel cameras and IMU axes (the camera fields are then unused).
  std::string rig = "ideal";
  // Cameras of the ideal rig: rectified stereo, cam1 at +baseline along cam0's x.
  int width = 400;
  int height = 225;
  double fx = 200.0, fy = 200.0, cx = 200.0, cy = 112.5;
  double baseline = 1.0;
  double cam_rate_hz = 20.0;
  double imu_rate_hz = 200.0;
  bool write_depth = true;  // GT depth of cam0 in depth0/
  bool shadows = true;      // sun shadows (one extra ray per lit pixel)

  // Trajectories.
  double length_m = 100.0;  // path length of each sequence
  double duration_s = 25.0;
  double height_01 = 4.0;       // flight height of *_01 sequences
  double height_02 = 15.0;      // flight height of *_02 sequences
  double spline_spacing = 6.0;  // B-spline control point spacing along the route (m)

  std::vector<std::string> sequences = {"S1_01", "S2_01"};
};

// Presets: tiny, paper, euroc (tiny's city shrunk to 3x3 blocks, EuRoC rig, 200 Hz IMU with
// EuRoC noise, 12 s / 36 m). Returns the preset's config; throws Error(kInvalidArgument) for an
// unknown name.
SimConfig PresetConfig(const std::string& name);
// Throws Error(kInvalidArgument) naming every bad field at once.
void Validate(const SimConfig& config);

}  // namespace mapdelta::sim
