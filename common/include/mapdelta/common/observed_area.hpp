#pragma once
// The observed area A_obs of the paper (Sec. III-B, step 3): the voxels that some keyframe's
// rays passed through or ended in, kept in an OctoMap OcTree of resolution rho_o. OctoMap stays
// inside observed_area.cpp (pimpl); this header is cheap to include.
#include <memory>
#include <string>

#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/point_cloud.hpp"
#include "mapdelta/common/pose.hpp"

namespace mapdelta {

struct ObservedAreaParams {
  double resolution_m = 0.8;  // rho_o: octree voxel edge
  double max_depth_m = 50.0;  // th_d: depths at or beyond this are not used as hits
  double free_ray_m = 20.0;   // th_f: depth of the free-space ray cast for pixels without depth
  double prefilter_voxel_m = 0.8;  // ray end points are voxel-filtered first (big speed-up)
  int pixel_stride = 1;            // use every n-th pixel in u and v
  // Free-ray bound (not in the paper). 0 = the paper's rule: every pixel without depth casts a
  // free ray of th_f. W > 0: such a ray ends at min(th_f, the smallest valid depth within
  // +-W pixels in u and v); with no valid depth in that window it stays th_f. Why: stereo
  // leaves holes on near surfaces (unmatched band, LR/uniqueness rejects, textureless walls);
  // a th_f ray through such a hole crosses the wall and marks prior points behind it observed,
  // which then become false "removed" points. Space before the nearest surface seen around
  // the pixel is known free; beyond it is unknown.
  int free_ray_bound_window_px = 0;
  // Confident free space (issue 21; not in the paper; 0 = the paper). A stereo depth d is
  // uncertain by sigma(d) = depth_sigma_per_m2 * d^2 (z = fx * B / disparity, so a disparity
  // error of s px moves z by z^2 * s / (fx * B)). A hit ray then proves free space only up to
  // d - depth_sigma_factor * sigma(d): the last stretch may be the surface itself seen too far
  // (a wall's depth overshooting behind it would otherwise carve the wall).
  double depth_sigma_per_m2 = 0.0;
  double depth_sigma_factor = 3.0;
  int threads = 0;  // for casting one keyframe's rays; 0 = every hardware thread (parallel.hpp)
};

// The prior map's surfaces as voxels of the observed area's grid (issue 21, not in the paper).
// Given to InsertKeyframe, a ray of a pixel without depth ends before the first prior voxel it
// meets: the pixel saw nothing, and a prior surface along it may be a textureless wall stereo
// could not match, so the ray proves nothing at or behind that surface. Rays of measured depths
// are not cut (a depth confidently beyond a prior surface is the evidence that it is gone).
class PriorSurfaces {
 public:
  PriorSurfaces(const PointCloud& prior_map, double resolution_m);
  ~PriorSurfaces();
  PriorSurfaces(PriorSurfaces&&) noexcept;
  PriorSurfaces& operator=(PriorSurfaces&&) noexcept;
  double resolution_m() const { return resolution_m_; }
  size_t NumVoxels() const;
  bool Contains(const Point& p_map) const;

 private:
  friend class ObservedArea;
  struct Impl;
  std::unique_ptr<Impl> impl_;
  double resolution_m_;
};

class ObservedArea {
 public:
  explicit ObservedArea(double resolution_m = 0.8);
  ~ObservedArea();
  ObservedArea(const ObservedArea& other);
  ObservedArea& operator=(const ObservedArea& other);
  ObservedArea(ObservedArea&&) noexcept;
  ObservedArea& operator=(ObservedArea&&) noexcept;

  // Rays from the camera centre to every valid depth < max_depth_m (end voxel occupied, the
  // rest free), and free rays to depth free_ray_m for pixels with no depth (for a depth beyond
  // max_depth_m: to min(depth, free_ray_m), space known to be free; with
  // free_ray_bound_window_px > 0 a no-depth ray is shortened, see ObservedAreaParams). Depth is
  // along the optical axis, so is a free ray's length. End points are voxel-filtered first. Throws
  // Error(kInvalidArgument) when the depth image does not match the camera or params are bad.
  // With `prior` (same resolution), rays of pixels without depth end before the prior's
  // surfaces (see PriorSurfaces).
  void InsertKeyframe(const PinholeCamera& camera, const SE3& T_map_cam, const DepthImage& depth,
                      const ObservedAreaParams& params, const PriorSurfaces* prior = nullptr);
  // True if the voxel holding p_map is known (free or occupied).
  bool IsObserved(const Point& p_map) const;
  // True if the voxel holding p_map is free with the evidence of at least `keyframes` free
  // observations net of hits (OctoMap log-odds <= keyframes * the log-odds of one miss). The
  // per-point evidence for a removed point: one keyframe's stray ray does not make a removal.
  // Evidence saturates at OctoMap's clamping (about 4.9 misses), so keyframes is at most 4.
  bool IsSeenFree(const Point& p_map, int keyframes) const;
  // Adds the other area's evidence (log-odds) voxel by voxel; resolutions must match.
  void Merge(const ObservedArea& other);

  // OctoMap .bt (readable by octovis and octomap tools): free or occupied per voxel, no more.
  // Read back, every free voxel holds OctoMap's clamped minimum, so IsSeenFree(p, k) is true
  // for any k: keep an area whose evidence is read again (a session's, on the server) with
  // SerializeEvidence. Load/Deserialize validate the whole stream before OctoMap sees it and
  // throw Error(kParse) naming the file or "octree bytes".
  void Save(const std::string& bt_path) const;
  static ObservedArea Load(const std::string& bt_path);
  std::string SerializeBinary() const;
  // OctoMap .ot: every voxel's log-odds, so IsSeenFree reads the same evidence after a round
  // trip (about 2.5x the bytes of .bt before compression).
  std::string SerializeEvidence() const;
  // Either format, told apart by the first line.
  static ObservedArea DeserializeBinary(const std::string& bytes);

  size_t NumKnownLeaves() const;
  double resolution_m() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mapdelta
