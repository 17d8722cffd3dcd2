#pragma once
// Renders one pinhole view of a Scene: one primary ray per pixel, Lambertian shading with sun,
// hard shadows and sky light, mirror reflections, a sky gradient. Shading is view-independent
// except for mirrors, so the two cameras of the stereo pair see consistent brightness.
#include <cstdint>
#include <vector>

#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/pose.hpp"
#include "mapdelta/sim/raycaster.hpp"
#include "mapdelta/sim/scene.hpp"

namespace mapdelta::sim {

struct RenderOptions {
  bool shadows = true;
  int max_bounces = 3;  // mirror reflections followed at most this often
};

struct RenderedView {
  int width = 0, height = 0;
  std::vector<float> intensity;  // display intensity in [0, 1], row-major
  std::vector<float> depth;      // z along the optical axis in metres; 0 = sky
};

// Renders the view of a camera at T_map_cam (x right, y down, z forward).
RenderedView RenderView(const Scene& scene, const RayCaster& caster, const PinholeCamera& camera,
                        const SE3& T_map_cam, const RenderOptions& options);
// Same, reusing out's buffers (large per-frame allocations cost page faults). `rays`, if given,
// holds every pixel's ray direction in the camera (z = 1; see PixelRays in sensor_rig.hpp), for
// distorted lenses; an all-zero ray renders black with depth 0.
void RenderViewInto(const Scene& scene, const RayCaster& caster, const PinholeCamera& camera,
                    const SE3& T_map_cam, const RenderOptions& options, RenderedView* out,
                    const std::vector<Eigen::Vector3f>* rays = nullptr);

// 8-bit grey image: intensity rounded to 8 bits, then AddImageNoise. The noise of pixel i is a
// hash of (noise_key, i): independent of thread scheduling.
std::vector<uint8_t> ToGrey8(const RenderedView& view, double sigma, uint64_t noise_key);
void ToGrey8Into(const RenderedView& view, double sigma, uint64_t noise_key,
                 std::vector<uint8_t>* out);
// Gaussian noise of `sigma` (fraction of full scale) added to a clean 8-bit image, rounded and
// clamped to [0, 255]; sigma 0 copies. `mapdelta-sim renoise` applies it to stored clean images.
void AddImageNoise(const std::vector<uint8_t>& clean, double sigma, uint64_t noise_key,
                   std::vector<uint8_t>* out);

}  // namespace mapdelta::sim
