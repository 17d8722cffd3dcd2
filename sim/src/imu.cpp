#include "mapdelta/sim/imu.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "mapdelta/sim/random.hpp"

namespace mapdelta::sim {
namespace {

// The value a reader of imu0/data.csv sees: the writer prints 10 significant digits.
double AsWritten(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.10g", v);
  return std::strtod(buf, nullptr);
}

}  // namespace

std::vector<ImuSample> SimulateCleanImu(const SplineTrajectory& traj, int64_t t0_ns, double rate_hz,
                                        double duration_s) {
  std::vector<ImuSample> out;
  const int64_t n = static_cast<int64_t>(std::floor(duration_s * rate_hz + 1e-9));
  out.reserve(static_cast<size_t>(n + 1));
  for (int64_t k = 0; k <= n; ++k) {
    const MotionState m = traj.Evaluate(static_cast<double>(k) / rate_hz);
    ImuSample s;
    s.t_ns = SampleTimeNs(t0_ns, k, rate_hz);
    // Noise is added to what the clean CSV holds, so `renoise` (which only has that file)
    // gives the same samples as the generator.
    for (int i = 0; i < 3; ++i) {
      s.gyro[i] = AsWritten(m.omega_body[i]);
      s.accel[i] = AsWritten(m.f_body[i]);
    }
    out.push_back(s);
  }
  return out;
}

std::vector<ImuSample> AddImuNoise(const std::vector<ImuSample>& clean, double rate_hz,
                                   const NoiseParams& noise, uint64_t seed) {
  Rng rng(HashCombine(seed, 0x1a0));
  const double dt = 1.0 / rate_hz;
  const double sg = noise.gyro_noise_density / std::sqrt(dt),
               sa = noise.accel_noise_density / std::sqrt(dt);
  const double wg = noise.gyro_random_walk * std::sqrt(dt),
               wa = noise.accel_random_walk * std::sqrt(dt);
  auto gauss3 = [&rng] { return Eigen::Vector3d(rng.Gaussian(), rng.Gaussian(), rng.Gaussian()); };
  std::vector<ImuSample> out;
  out.reserve(clean.size());
  Eigen::Vector3d bg = Eigen::Vector3d::Zero(), ba = Eigen::Vector3d::Zero();
  for (const ImuSample& c : clean) {
    ImuSample s;
    s.t_ns = c.t_ns;
    s.bias_gyro = bg;
    s.bias_accel = ba;
    // Always draw, even with zero sigma, so the random stream does not depend on the preset.
    const Eigen::Vector3d ng = gauss3(), na = gauss3(), nbg = gauss3(), nba = gauss3();
    s.gyro = c.gyro + bg + sg * ng;
    s.accel = c.accel + ba + sa * na;
    bg += wg * nbg;
    ba += wa * nba;
    out.push_back(s);
  }
  return out;
}

std::vector<ImuSample> SimulateImu(const SplineTrajectory& traj, int64_t t0_ns, double rate_hz,
                                   double duration_s, const NoiseParams& noise, uint64_t seed) {
  return AddImuNoise(SimulateCleanImu(traj, t0_ns, rate_hz, duration_s), rate_hz, noise, seed);
}

}  // namespace mapdelta::sim
