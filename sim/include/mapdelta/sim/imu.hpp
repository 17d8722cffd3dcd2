#pragma once
// IMU measurements from a trajectory's analytic derivatives, plus the EuRoC-style noise model:
// white noise with continuous density sigma (discrete sigma = density * sqrt(rate)) and a bias
// random walk (discrete step = walk * sqrt(dt)). Biases start at zero.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <vector>

#include "mapdelta/sim/config.hpp"
#include "mapdelta/sim/trajectory.hpp"

namespace mapdelta::sim {

struct ImuSample {
  int64_t t_ns = 0;
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();   // rad/s, body frame
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();  // m/s^2, body frame (specific force)
  Eigen::Vector3d bias_gyro = Eigen::Vector3d::Zero();
  Eigen::Vector3d bias_accel = Eigen::Vector3d::Zero();
};

// Sample k is at t = k / rate_hz seconds after t0_ns (rounded to the nanosecond), for every t
// in [0, duration_s]. Equals AddImuNoise(SimulateCleanImu(...), rate_hz, noise, seed).
std::vector<ImuSample> SimulateImu(const SplineTrajectory& trajectory, int64_t t0_ns,
                                   double rate_hz, double duration_s, const NoiseParams& noise,
                                   uint64_t seed);

// Noise-free samples (zero biases), each value rounded as imu0/data.csv writes it (10
// significant digits), so noise added later to a clean file's values matches the generator.
std::vector<ImuSample> SimulateCleanImu(const SplineTrajectory& trajectory, int64_t t0_ns,
                                        double rate_hz, double duration_s);
// White noise and bias random walk on top of clean samples; one random stream from `seed`,
// drawn in sample order (the same draws whatever the noise level).
std::vector<ImuSample> AddImuNoise(const std::vector<ImuSample>& clean, double rate_hz,
                                   const NoiseParams& noise, uint64_t seed);

// Time of sample k at rate_hz, in ns after t0 (exact for rates dividing 1e9).
inline int64_t SampleTimeNs(int64_t t0_ns, int64_t k, double rate_hz) {
  return t0_ns + static_cast<int64_t>(std::llround(static_cast<double>(k) * 1e9 / rate_hz));
}

}  // namespace mapdelta::sim
