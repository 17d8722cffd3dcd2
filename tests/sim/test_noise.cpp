// Noise statistics match the presets: IMU white noise (discrete sigma = density * sqrt(rate)),
// bias random walk (step sigma = walk * sqrt(dt)), image gaussian sigma.
#include <gtest/gtest.h>

#include <cmath>

#include "mapdelta/sim/imu.hpp"
#include "mapdelta/sim/renderer.hpp"
#include "mapdelta/sim/trajectory.hpp"

namespace mapdelta::sim {
namespace {

SplineTrajectory Line() {
  std::vector<Eigen::Vector3d> control;
  for (int i = 0; i < 200; ++i) control.emplace_back(i * 2.0, 0.3 * std::sin(i * 0.5), 4.0);
  return SplineTrajectory(control, 0.5);
}

double Std(const std::vector<double>& x) {
  double m = 0, s = 0;
  for (double v : x) m += v;
  m /= static_cast<double>(x.size());
  for (double v : x) s += (v - m) * (v - m);
  return std::sqrt(s / static_cast<double>(x.size() - 1));
}

TEST(SimNoise, ImuWhiteNoiseAndBiasWalkMatchPreset) {
  for (NoiseLevel level : {NoiseLevel::kSmall, NoiseLevel::kBig}) {
    const NoiseParams p = NoiseFor(level);
    const SplineTrajectory traj = Line();
    const double rate = 200;
    const auto noisy = SimulateImu(traj, 0, rate, 90.0, p, 11);
    const auto clean = SimulateImu(traj, 0, rate, 90.0, NoiseFor(NoiseLevel::kNone), 11);
    ASSERT_EQ(noisy.size(), clean.size());
    std::vector<double> gw, aw, gb, ab;
    for (size_t k = 0; k < noisy.size(); ++k) {
      for (int i = 0; i < 3; ++i) {
        gw.push_back(noisy[k].gyro[i] - clean[k].gyro[i] - noisy[k].bias_gyro[i]);
        aw.push_back(noisy[k].accel[i] - clean[k].accel[i] - noisy[k].bias_accel[i]);
        if (k > 0) {
          gb.push_back(noisy[k].bias_gyro[i] - noisy[k - 1].bias_gyro[i]);
          ab.push_back(noisy[k].bias_accel[i] - noisy[k - 1].bias_accel[i]);
        }
      }
    }
    // ~54000 samples each: the sample std is within ~1% of the truth; allow 4%.
    EXPECT_NEAR(Std(gw), p.gyro_noise_density * std::sqrt(rate),
                0.04 * p.gyro_noise_density * std::sqrt(rate));
    EXPECT_NEAR(Std(aw), p.accel_noise_density * std::sqrt(rate),
                0.04 * p.accel_noise_density * std::sqrt(rate));
    EXPECT_NEAR(Std(gb), p.gyro_random_walk / std::sqrt(rate),
                0.04 * p.gyro_random_walk / std::sqrt(rate));
    EXPECT_NEAR(Std(ab), p.accel_random_walk / std::sqrt(rate),
                0.04 * p.accel_random_walk / std::sqrt(rate));
  }
  // The paper's table values.
  EXPECT_DOUBLE_EQ(NoiseFor(NoiseLevel::kSmall).gyro_noise_density, 4.0e-4);
  EXPECT_DOUBLE_EQ(NoiseFor(NoiseLevel::kBig).accel_noise_density, 3.0e-2);
  EXPECT_DOUBLE_EQ(NoiseFor(NoiseLevel::kBig).image_sigma, 0.04);
  EXPECT_EQ(NoiseFor(NoiseLevel::kNone).accel_random_walk, 0.0);
}

TEST(SimNoise, ImageNoiseSigmaMatchesPresetAndIsSeeded) {
  RenderedView v;
  v.width = 400;
  v.height = 250;
  v.intensity.assign(100000, 0.5f);
  for (NoiseLevel level : {NoiseLevel::kSmall, NoiseLevel::kBig}) {
    const double sigma = NoiseFor(level).image_sigma;
    const auto img = ToGrey8(v, sigma, 42);
    std::vector<double> x(img.begin(), img.end());
    double mean = 0;
    for (double p : x) mean += p;
    mean /= static_cast<double>(x.size());
    // The noise is added to the 8-bit clean value (128: 0.5 * 255 rounds up), not to 127.5, so
    // that renoise reproduces it from stored clean images.
    EXPECT_NEAR(mean, 128.0, 0.3);
    // Rounding to integers adds 1/12 to the variance.
    EXPECT_NEAR(Std(x), std::sqrt(std::pow(sigma * 255, 2) + 1.0 / 12), 0.03 * sigma * 255);
    EXPECT_EQ(img, ToGrey8(v, sigma, 42));
    EXPECT_NE(img, ToGrey8(v, sigma, 43));
  }
  const auto clean = ToGrey8(v, 0.0, 42);
  for (uint8_t p : clean) ASSERT_EQ(p, 128);  // 0.5 * 255 = 127.5 rounds up
}

}  // namespace
}  // namespace mapdelta::sim
