#pragma once
// Stereo rectification for cameras that are not already a rectified pinhole pair (real EuRoC:
// radial-tangential lenses, the two cameras ~1 degree from parallel). The VIO's front end (row
// search for stereo matches) and the client's stereo depth (SGBM) need rectified, undistorted
// images, so pairs are remapped once on input and every stage runs on the rectified cameras.
// Narrow header (OpenCV types): included by the rectifying sources and tests only.
#include <opencv2/core.hpp>

#include <memory>

#include "mapdelta/common/euroc.hpp"

namespace mapdelta {

// True if the pair already is what the front end needs: no distortion, equal rotations, cam1
// at +x of cam0 (the tolerances of the estimator's checks).
bool IsRectifiedPair(const EurocCamera& cam0, const EurocCamera& cam1);

class StereoRectifier {
 public:
  // OpenCV stereoRectify (zero disparity at infinity, alpha 0: every output pixel sees the
  // scene, no black borders whose edges would attract corners) and float remap tables.
  // Throws Error(kUnsupported) for a distortion model other than radial-tangential (4 or 5
  // coefficients) or when cam1 is not beside cam0 (translation mostly along cam0's x).
  StereoRectifier(const EurocCamera& cam0, const EurocCamera& cam1);

  // Rectified cameras: input resolution, shared pinhole intrinsics (fx = fy), no distortion,
  // T_body_cam = input T_body_cam * R_rect^T (optical centres unchanged), cam1 at +baseline
  // along cam0's x with cam0's rotation.
  const EurocCamera& cam0() const { return rect_[0]; }
  const EurocCamera& cam1() const { return rect_[1]; }
  double baseline_m() const { return baseline_m_; }

  // Rectified image of camera `index` (0 left, 1 right): bilinear remap of `in` (8-bit grey,
  // input resolution). Throws Error(kInvalidArgument) on a size mismatch.
  void Rectify(int index, const cv::Mat& in, cv::Mat* out) const;
  // Input pixel seen by rectified pixel (u, v) of camera `index` (bilinear in the tables).
  cv::Point2d SourcePixel(int index, double u, double v) const;

 private:
  EurocCamera rect_[2];
  double baseline_m_ = 0;
  cv::Mat map_x_[2], map_y_[2];  // CV_32FC1: rectified pixel -> input pixel
  // The same tables in OpenCV's fixed-point form (CV_16SC2 integer pixel + CV_16UC1 1/32-pixel
  // interpolation index), which remap reads with SIMD: what Rectify uses on every image.
  cv::Mat map_fixed_[2], map_fraction_[2];
};

// The rectifier this pair needs, or nullptr if it is already rectified.
std::unique_ptr<StereoRectifier> MakeRectifierIfNeeded(const EurocCamera& cam0,
                                                       const EurocCamera& cam1);

}  // namespace mapdelta
