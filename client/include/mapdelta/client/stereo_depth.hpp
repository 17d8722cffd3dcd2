#pragma once
// Stage 1: dense depth from a rectified stereo pair by OpenCV's semi-global matching
// (StereoSGBM) with the left-right check, a uniqueness margin, subpixel (1/16 px) disparity
// and speckle removal. Computed for keyframes only.
#include <memory>

#include "mapdelta/client/config.hpp"
#include "mapdelta/client/image.hpp"
#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/depth_image.hpp"

namespace mapdelta::client {

// Standard deviation of an image's pixel noise in grey levels: Immerkaer's filter (the
// difference of two Laplacians, which cancels smooth image content) with the median of its
// magnitude instead of the mean, so the edges of real texture do not count as noise (Middlebury
// Cones: 4.3 by the mean, 2.7 by the median). Measured: simulator 0.3 without noise, 5.2 with
// the small preset, 10.1 on the dark scene with the big one; real EuRoC V1_01 1.7.
double EstimateImageNoise(const GrayImage& image);

// Sigma (pixels at StereoConfig::reference_width, 800; scaled with the image width) of the
// Gaussian smoothing before matching for images with this noise: 0.5 px per grey level above 2,
// at most 2 px, none under 0.5 px. Why: SGBM's matching costs on raw pixels follow the noise;
// smoothing first averages it out, at a cost at depth edges. Against ground truth (paper-preset
// frames, 800 px, fx * B = 400 m px, every 30th frame): the dark scene with big noise (10 grey
// levels) goes from 9.7 % to 50 % of pixels with a depth (7.0 % -> 32 % of all pixels within 3
// sigma of the truth) at sigma 2; the small-noise simulator (5.2; S1_01, every 15th frame) from
// 56 % to 74 % at 1.6 px, with fewer gross errors (78 % -> 85 % of depths within 3 sigma). The
// denser depth also reaches the ground past the map's edge, which made false new points until new
// points were kept to the prior's footprint (change_detection.hpp); with that rule, paper S1_01
// small goes R_rm 0.77 -> 0.84, P_new 0.90 -> 0.95 (docs/results.md, 2026-12-06). On clean real
// pairs (Middlebury 2.7, real EuRoC 1.7) it would only blur. Scaled with the width because what it
// costs at edges grows with its size against the structures: 1.6 px on the tiny preset's 400 px
// frames cut S1_01's new-point precision 0.89 -> 0.78, 0.8 px kept 0.88.
double DenoiseSigmaFor(double noise);

class StereoDepth {
 public:
  explicit StereoDepth(const StereoConfig& config);
  ~StereoDepth();
  StereoDepth(StereoDepth&&) noexcept;
  StereoDepth& operator=(StereoDepth&&) noexcept;

  // Disparity search range actually used for an image of this width: num_disparities scaled
  // by width / reference_width, rounded up to a multiple of 16 (SGBM's requirement).
  int NumDisparitiesFor(int width) const;
  // Width of the left band SGBM cannot match by construction (u < min_disparity +
  // NumDisparitiesFor(width): the right image holds no candidate), clamped to [0, width - 1].
  int UnmatchedBandFor(int width) const;
  // Smooths both images first as StereoConfig::denoise_sigma_px says.
  // Throws Error(kInvalidArgument) if the images are empty or differ in size.
  DisparityImage ComputeDisparity(const GrayImage& left, const GrayImage& right) const;
  // depth = fx * baseline / d; 0 where invalid or beyond max_depth_m.
  DepthImage ComputeDepth(const GrayImage& left, const GrayImage& right,
                          const StereoRig& rig) const;
  static DepthImage DepthFromDisparity(const DisparityImage& disparity, const StereoRig& rig,
                                       double max_depth_m);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Keyframe output without the unmatched left band: its pixels are "unknown", not "no surface",
// and in the keyframe folder / upload they would cast the observed area's th_f free rays
// through whatever lies there. Drops the first `band` columns; cx moves by -band so every kept
// pixel keeps its ray. Throws Error(kInvalidArgument) if band is outside [0, width).
PinholeCamera CropLeftBand(const PinholeCamera& camera, int band);
DepthImage CropLeftBand(const DepthImage& depth, int band);

}  // namespace mapdelta::client
