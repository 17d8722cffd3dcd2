#pragma once
// Reader for EuRoC/ASL-layout sequences (docs/conventions.md): camera and IMU sensor.yaml
// files, image lists, IMU samples, ground truth and optional depth. Returns image *paths*;
// image decoding is left to the caller so this header stays free of OpenCV.
// Every error names the file (and field or line) and what was expected.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/pose.hpp"

namespace mapdelta {

// One camera's sensor.yaml.
struct EurocCamera {
  SE3 T_body_cam = SE3::Identity();  // T_BS
  double rate_hz = 0.0;
  PinholeCamera intrinsics;        // width/height from `resolution`, fx fy cx cy
  std::string distortion_model;    // e.g. "radial-tangential", "equidistant"
  std::vector<double> distortion;  // distortion_coefficients (may be empty)
  bool HasDistortion() const;      // any non-zero coefficient
};

// Continuous-time noise densities as EuRoC states them (per sqrt(Hz)); the VIO converts them
// to discrete noise for its sample period explicitly.
struct ImuNoiseDensities {
  double gyroscope_noise_density = 0.0;      // rad / s / sqrt(Hz)
  double gyroscope_random_walk = 0.0;        // rad / s^2 / sqrt(Hz)
  double accelerometer_noise_density = 0.0;  // m / s^2 / sqrt(Hz)
  double accelerometer_random_walk = 0.0;    // m / s^3 / sqrt(Hz)
};

struct EurocImu {
  SE3 T_body_imu = SE3::Identity();  // T_BS (identity in EuRoC: body is the IMU)
  double rate_hz = 0.0;
  ImuNoiseDensities noise;
};

struct ImuSample {
  int64_t t_ns = 0;
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();   // w_RS_S, rad/s
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();  // a_RS_S, m/s^2 (specific force)
};

struct EurocImage {
  int64_t t_ns = 0;
  std::string path;  // absolute or relative to the working directory, ready to open
};

struct StereoFrameFiles {
  int64_t t_ns = 0;
  std::string left_path;
  std::string right_path;
};

struct EurocSequence {
  std::string mav0_dir;
  EurocCamera cam0, cam1;
  std::vector<EurocImage> cam0_images, cam1_images;
  EurocImu imu;
  std::vector<ImuSample> imu_samples;
  Trajectory groundtruth;                 // T_map_body; empty if the folder has none
  std::vector<EurocImage> depth0_images;  // empty if the folder has no depth0

  // Left/right images with equal timestamps, in time order (unpaired images are skipped).
  std::vector<StereoFrameFiles> StereoFrames() const;
  // T_cam0_cam1 from the two T_BS.
  SE3 T_cam0_cam1() const;
};

// `dir` is the sequence folder (containing mav0/) or the mav0 folder itself.
// Ground truth and depth0 are optional; cam0, cam1 and imu0 are required.
EurocSequence ReadEurocSequence(const std::string& dir);

// The parts, for callers that need only one.
EurocCamera ReadEurocCameraYaml(const std::string& path);
EurocImu ReadEurocImuYaml(const std::string& path);
// data.csv "#timestamp [ns],filename"; paths are joined to `data_dir`.
std::vector<EurocImage> ReadEurocImageList(const std::string& csv_path,
                                           const std::string& data_dir);
// data.csv "#timestamp [ns],w_x,w_y,w_z,a_x,a_y,a_z".
std::vector<ImuSample> ReadEurocImuCsv(const std::string& csv_path);
// A rectified stereo rig from cam0/cam1 (baseline = |t of T_cam0_cam1|); throws
// kUnsupported if the pair is not rectified (distortion, rotation, or offset off cam0's x).
StereoRig MakeRectifiedStereoRig(const EurocSequence& sequence);

}  // namespace mapdelta
