#pragma once
// Pixel noise of 8-bit grey images, and the Gaussian smoothing it calls for before matching
// (stereo, client stereo_depth.hpp) and before corner detection and tracking (the VIO front
// end, client/vio feature_tracker_config.hpp).
#include <cstddef>
#include <cstdint>

namespace mapdelta {

// Standard deviation of an image's pixel noise in grey levels: Immerkaer's filter (the
// difference of two Laplacians, which cancels smooth image content) with the median of its
// magnitude instead of the mean, so the edges of real texture do not count as noise (Middlebury
// Cones: 4.3 by the mean, 2.7 by the median). Measured: simulator 0.3 without noise, 5.2 with
// the small preset, 10.1 on the dark scene with the big one; real EuRoC V1_01 1.7. `stride` is
// the distance between rows in bytes; 0 for images smaller than 3x3.
double EstimateImageNoise(int width, int height, size_t stride, const uint8_t* pixels);

// Sigma (pixels at an 800 px wide image; callers scale it with their width) of the Gaussian
// smoothing for images with this noise: 0.5 px per grey level above 2, at most 2 px, none under
// 0.5 px. Why: matching costs on raw pixels follow the noise; smoothing first averages it out,
// at a cost at depth edges. Against ground truth (paper-preset frames, 800 px, fx * B = 400 m
// px, every 30th frame): the dark scene with big noise (10 grey levels) goes from 9.7 % to 50 %
// of pixels with a stereo depth (7.0 % -> 32 % of all pixels within 3 sigma of the truth) at
// sigma 2; the small-noise simulator (5.2; S1_01, every 15th frame) from 56 % to 74 % at 1.6 px,
// with fewer gross errors (78 % -> 85 % of depths within 3 sigma). The denser depth also
// reaches the ground past the map's edge, which made false new points until new points were
// kept to the prior's footprint (change_detection.hpp); with that rule, paper S1_01 small goes
// R_rm 0.77 -> 0.84, P_new 0.90 -> 0.95 (docs/results.md, 2026-12-06). On clean real pairs
// (Middlebury 2.7, real EuRoC 1.7) it would only blur. Scaled with the width because what it
// costs at edges grows with its size against the structures: 1.6 px on the tiny preset's 400 px
// frames cut S1_01's new-point precision 0.89 -> 0.78, 0.8 px kept 0.88.
double DenoiseSigmaFor(double noise);

}  // namespace mapdelta
