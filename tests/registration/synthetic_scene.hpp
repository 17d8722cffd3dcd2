#pragma once
// Urban-like synthetic geometry for registration tests: a ground plane with a few boxes
// (buildings) and poles, sampled uniformly on the surfaces, with Gaussian noise. Each call
// draws a fresh sample, so source and target never share points (as real scans).
#include <random>

#include "mapdelta/common/point_cloud.hpp"

namespace mapdelta::test {

// Samples about `num_points` points over a 40 x 40 m patch centred on the origin, with
// isotropic Gaussian noise of `noise_m` standard deviation.
PointCloud SampleUrbanScene(size_t num_points, double noise_m, std::mt19937& rng);

}  // namespace mapdelta::test
