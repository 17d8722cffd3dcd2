#pragma once
// Procedural grey-level textures (albedo in [0, 1]) for the city: asphalt with lane markings,
// paving, grass, brick/plaster/concrete facades with windows, roofs, cars, trees.
// Every pattern is band-limited by the pixel footprint (metres covered by one pixel at the
// hit): noise octaves above the footprint's Nyquist rate fade to their mean and line patterns
// are box-filtered analytically. Without that, one ray per pixel would alias, and aliasing
// differs between the left and right views, which would break stereo matching.
#include <Eigen/Core>

#include "mapdelta/sim/raycaster.hpp"
#include "mapdelta/sim/scene.hpp"

namespace mapdelta::sim {

// Albedo at world point p on the surface hit; footprint_m > 0.
float SurfaceAlbedo(const Scene& scene, const Hit& hit, const Eigen::Vector3f& p,
                    float footprint_m);

// Building blocks, exposed for tests.
// Smooth value noise in [0, 1] on a unit lattice.
float ValueNoise(float x, float y, uint32_t seed);
// Sum of `octaves` noise octaves from base_freq (cycles/m), each faded out when its frequency
// exceeds what the footprint resolves; result centred on 0, roughly in [-0.5, 0.5].
float BandLimitedNoise(float x, float y, float base_freq, int octaves, float gain, float footprint,
                       uint32_t seed);
// Fraction of [x - w/2, x + w/2] covered by a periodic pulse that is "on" on [0, on) of every
// period (box-filtered square wave).
float FilteredPulse(float x, float period, float on, float w);

}  // namespace mapdelta::sim
