#pragma once
// Writers for the dataset layout of docs/conventions.md (EuRoC/ASL folders + scenes).
// Every writer throws Error(kIo) naming the file it could not write.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/pose.hpp"
#include "mapdelta/sim/config.hpp"
#include "mapdelta/sim/imu.hpp"
#include "mapdelta/sim/scene.hpp"

namespace mapdelta::sim {

// How every number in the CSV and YAML files is printed (10 significant digits).
std::string FormatCsvNumber(double value);

// Body (FLU) to camera (RDF) extrinsics of cam0; cam1 is at +baseline along cam0's x.
SE3 BodyToCam0();

// `radtan`: k1 k2 p1 p2 written as distortion_coefficients (radial-tangential, as EuRoC).
void WriteCameraYaml(const std::string& path, const PinholeCamera& camera, double rate_hz,
                     const SE3& T_body_cam, const std::string& comment,
                     const std::array<double, 4>& radtan = {0, 0, 0, 0});
void WriteImuYaml(const std::string& path, double rate_hz, const NoiseParams& noise);
void WriteImageCsv(const std::string& path, const std::vector<int64_t>& t_ns);
void WriteImuCsv(const std::string& path, const std::vector<ImuSample>& imu);
// EuRoC ground truth: t, p, q (w x y z), v, gyro bias, accel bias; one row per IMU sample.
// The pose written is T_map_vehicle * T_vehicle_body (a pure rotation: same position); the
// biases are the samples' own (already in the body frame).
void WriteGroundTruthCsv(const std::string& path, const SplineTrajectory& trajectory,
                         const std::vector<ImuSample>& imu, int64_t t0_ns,
                         const SE3& T_vehicle_body = SE3::Identity());
// objects.json: objects with boxes and bounds; `changes` relative to the original scene.
void WriteObjectsJson(const std::string& path, const Scene& scene,
                      const std::vector<Change>& changes);
// A grey 8-bit PNG.
void WriteGreyPng(const std::string& path, int width, int height,
                  const std::vector<uint8_t>& pixels);

}  // namespace mapdelta::sim
