#pragma once
// Stage 1: dense depth from a rectified stereo pair by OpenCV's semi-global matching
// (StereoSGBM) with the left-right check, a uniqueness margin, subpixel (1/16 px) disparity
// and speckle removal. Computed for keyframes only.
#include <memory>

#include "mapdelta/client/config.hpp"
#include "mapdelta/client/image.hpp"
#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "mapdelta/common/image_noise.hpp"

namespace mapdelta::client {

// common's EstimateImageNoise of a client image; the smoothing before matching is common's
// DenoiseSigmaFor of it (StereoConfig::denoise_sigma_px -1), scaled from 800 px to the width.
double EstimateImageNoise(const GrayImage& image);

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
