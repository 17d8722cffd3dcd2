#include "mapdelta/common/stereo_rectifier.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <string>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"

namespace mapdelta {
namespace {

cv::Mat CameraMatrix(const PinholeCamera& k) {
  return (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
}

cv::Mat DistortionVector(const EurocCamera& cam, const char* name) {
  if (!cam.HasDistortion()) return cv::Mat::zeros(1, 4, CV_64F);
  const std::string& m = cam.distortion_model;
  const bool radtan = m == "radial-tangential" || m == "radtan" || m == "plumb_bob" || m.empty();
  if (!radtan || (cam.distortion.size() != 4 && cam.distortion.size() != 5)) {
    throw Error(ErrorCode::kUnsupported,
                std::string("stereo rectifier: ") + name + " distortion_model '" + m + "' with " +
                    std::to_string(cam.distortion.size()) +
                    " coefficients: only radial-tangential (k1 k2 p1 p2 [k3]) is supported");
  }
  cv::Mat d(1, static_cast<int>(cam.distortion.size()), CV_64F);
  for (size_t i = 0; i < cam.distortion.size(); ++i)
    d.at<double>(0, static_cast<int>(i)) = cam.distortion[i];
  return d;
}

cv::Mat ToCv(const Eigen::Matrix3d& m) {
  cv::Mat out(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.at<double>(r, c) = m(r, c);
  }
  return out;
}

Eigen::Matrix3d ToEigen(const cv::Mat& m) {
  Eigen::Matrix3d out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out(r, c) = m.at<double>(r, c);
  }
  return out;
}

}  // namespace

bool IsRectifiedPair(const EurocCamera& cam0, const EurocCamera& cam1) {
  if (cam0.HasDistortion() || cam1.HasDistortion()) return false;
  const SE3 T = cam0.T_body_cam.inverse() * cam1.T_body_cam;
  return RotationAngle(T, SE3::Identity()) <= 1e-3 && T.translation().x() > 0 &&
         std::hypot(T.translation().y(), T.translation().z()) <= 1e-2 * T.translation().norm();
}

StereoRectifier::StereoRectifier(const EurocCamera& cam0, const EurocCamera& cam1) {
  cam0.intrinsics.Validate();
  cam1.intrinsics.Validate();
  if (cam0.intrinsics.width != cam1.intrinsics.width ||
      cam0.intrinsics.height != cam1.intrinsics.height) {
    throw Error(ErrorCode::kUnsupported, "stereo rectifier: cam0 and cam1 resolutions differ");
  }
  const SE3 T_cam0_cam1 = cam0.T_body_cam.inverse() * cam1.T_body_cam;
  const Eigen::Vector3d t01 = T_cam0_cam1.translation();
  // Horizontal stereo only: the front end searches matches along rows, right camera at +x.
  if (!(t01.x() > 0.7 * t01.norm())) {
    throw Error(ErrorCode::kUnsupported,
                "stereo rectifier: cam1 must sit to the right of cam0 (T_cam0_cam1 translation "
                "mostly +x), got (" +
                    std::to_string(t01.x()) + ", " + std::to_string(t01.y()) + ", " +
                    std::to_string(t01.z()) + ")");
  }
  const cv::Mat K0 = CameraMatrix(cam0.intrinsics), K1 = CameraMatrix(cam1.intrinsics);
  const cv::Mat D0 = DistortionVector(cam0, "cam0"), D1 = DistortionVector(cam1, "cam1");
  // OpenCV wants x1 = R x0 + T, i.e. T_cam1_cam0.
  const SE3 T_cam1_cam0 = T_cam0_cam1.inverse();
  const cv::Mat R = ToCv(T_cam1_cam0.linear());
  const cv::Mat T = (cv::Mat_<double>(3, 1) << T_cam1_cam0.translation().x(),
                     T_cam1_cam0.translation().y(), T_cam1_cam0.translation().z());
  const cv::Size size(cam0.intrinsics.width, cam0.intrinsics.height);
  cv::Mat R1, R2, P1, P2, Q;
  cv::stereoRectify(K0, D0, K1, D1, size, R, T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, 0.0,
                    size);
  const double f = P1.at<double>(0, 0);
  baseline_m_ = -P2.at<double>(0, 3) / P2.at<double>(0, 0);
  if (!(f > 0) || !(baseline_m_ > 0) || !std::isfinite(baseline_m_)) {
    throw Error(ErrorCode::kUnsupported, "stereo rectification failed (focal " + std::to_string(f) +
                                             ", baseline " + std::to_string(baseline_m_) + ")");
  }
  const cv::Mat* Rs[2] = {&R1, &R2};
  const cv::Mat* Ps[2] = {&P1, &P2};
  const EurocCamera* in[2] = {&cam0, &cam1};
  const cv::Mat* Ks[2] = {&K0, &K1};
  const cv::Mat* Ds[2] = {&D0, &D1};
  for (int i = 0; i < 2; ++i) {
    EurocCamera& out = rect_[i];
    out = *in[i];
    out.intrinsics.fx = Ps[i]->at<double>(0, 0);
    out.intrinsics.fy = Ps[i]->at<double>(1, 1);
    out.intrinsics.cx = Ps[i]->at<double>(0, 2);
    out.intrinsics.cy = Ps[i]->at<double>(1, 2);
    out.distortion_model = "none";
    out.distortion.clear();
    // x_rect = R_i x_cam: the rectified camera is the input one turned by R_i^T.
    SE3 T_cam_rect = SE3::Identity();
    T_cam_rect.linear() = ToEigen(*Rs[i]).transpose();
    out.T_body_cam = in[i]->T_body_cam * T_cam_rect;
    cv::initUndistortRectifyMap(*Ks[i], *Ds[i], *Rs[i], *Ps[i], size, CV_32FC1, map_x_[i],
                                map_y_[i]);
    cv::convertMaps(map_x_[i], map_y_[i], map_fixed_[i], map_fraction_[i], CV_16SC2);
  }
  // Pixels whose source lies outside the input image (alpha 0 keeps them to a thin rim at most).
  int outside = 0;
  for (int i = 0; i < 2; ++i) {
    for (int v = 0; v < size.height; ++v) {
      for (int u = 0; u < size.width; ++u) {
        const float x = map_x_[i].at<float>(v, u), y = map_y_[i].at<float>(v, u);
        if (x < -0.5f || y < -0.5f || x > size.width - 0.5f || y > size.height - 0.5f) ++outside;
      }
    }
  }
  MD_LOG(kInfo, "rectifying stereo: f " << f << " px, c (" << rect_[0].intrinsics.cx << ", "
                                        << rect_[0].intrinsics.cy << "), baseline " << baseline_m_
                                        << " m, " << outside << " output pixels outside the input");
}

void StereoRectifier::Rectify(int index, const cv::Mat& in, cv::Mat* out) const {
  const auto& k = rect_[index].intrinsics;
  if (in.cols != k.width || in.rows != k.height || in.type() != CV_8UC1) {
    throw Error(ErrorCode::kInvalidArgument,
                "stereo rectifier expects 8-bit grey " + std::to_string(k.width) + "x" +
                    std::to_string(k.height) + " images for cam" + std::to_string(index));
  }
  // Replicated borders: a source pixel just outside the image repeats the edge, never black.
  // Fixed-point tables (1/32-pixel bilinear weights), which remap interpolates with SIMD integer
  // arithmetic; the float ones stay for SourcePixel.
  cv::remap(in, *out, map_fixed_[index], map_fraction_[index], cv::INTER_LINEAR,
            cv::BORDER_REPLICATE);
}

cv::Point2d StereoRectifier::SourcePixel(int index, double u, double v) const {
  const cv::Mat& mx = map_x_[index];
  const cv::Mat& my = map_y_[index];
  const int u0 = std::clamp(static_cast<int>(std::floor(u)), 0, mx.cols - 2);
  const int v0 = std::clamp(static_cast<int>(std::floor(v)), 0, mx.rows - 2);
  const double a = u - u0, b = v - v0;
  auto lerp = [&](const cv::Mat& m) {
    return (1 - a) * (1 - b) * m.at<float>(v0, u0) + a * (1 - b) * m.at<float>(v0, u0 + 1) +
           (1 - a) * b * m.at<float>(v0 + 1, u0) + a * b * m.at<float>(v0 + 1, u0 + 1);
  };
  return {lerp(mx), lerp(my)};
}

std::unique_ptr<StereoRectifier> MakeRectifierIfNeeded(const EurocCamera& cam0,
                                                       const EurocCamera& cam1) {
  if (IsRectifiedPair(cam0, cam1)) return nullptr;
  return std::make_unique<StereoRectifier>(cam0, cam1);
}

}  // namespace mapdelta
