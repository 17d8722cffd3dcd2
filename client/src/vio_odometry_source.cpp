#include "mapdelta/client/vio_odometry_source.hpp"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <map>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/vio/odometry.hpp"

namespace mapdelta::client {

struct VioOdometrySource::Impl {
  const EurocSequence* sequence = nullptr;
  std::unique_ptr<vio::StereoInertialOdometry> vio;
  std::map<int64_t, StereoFrameFiles> frames;
  size_t next_imu = 0;
  int resets = 0;  // also the segment of the poses reported now
};

VioOdometrySource::VioOdometrySource(const EurocSequence& sequence) : impl_(std::make_unique<Impl>()) {
  impl_->sequence = &sequence;
  vio::VioConfig config;
  // The fusion's odometry factors use the configured sigmas (client/README.md, known limits):
  // the VIO's per-keyframe relative covariance (a Schur complement of the whole window, ~5 % of
  // its CPU at 800x450) would be computed for nothing.
  config.compute_keyframe_covariance = false;
  impl_->vio = std::make_unique<vio::StereoInertialOdometry>(config, sequence.cam0, sequence.cam1, sequence.imu);
  for (const auto& f : sequence.StereoFrames()) impl_->frames[f.t_ns] = f;
}

VioOdometrySource::~VioOdometrySource() = default;

int VioOdometrySource::resets() const { return impl_->resets; }

std::optional<OdometrySample> VioOdometrySource::At(int64_t t_ns) {
  const auto it = impl_->frames.find(t_ns);
  if (it == impl_->frames.end()) return std::nullopt;
  // IMU up to and one past the frame time, as the VIO's API asks.
  const auto& imu = impl_->sequence->imu_samples;
  while (impl_->next_imu < imu.size()) {
    const bool past = imu[impl_->next_imu].t_ns > t_ns;
    impl_->vio->AddImu(imu[impl_->next_imu++]);
    if (past) break;
  }
  const cv::Mat left = cv::imread(it->second.left_path, cv::IMREAD_GRAYSCALE);
  const cv::Mat right = cv::imread(it->second.right_path, cv::IMREAD_GRAYSCALE);
  if (left.empty() || right.empty()) throw Error(ErrorCode::kIo, it->second.left_path + ": cannot read stereo frame");
  const vio::GrayImageView lv{left.cols, left.rows, static_cast<int>(left.step), left.data};
  const vio::GrayImageView rv{right.cols, right.rows, static_cast<int>(right.step), right.data};
  const vio::FrameEstimate e = impl_->vio->AddStereoFrame(t_ns, lv, rv);
  if (e.reset) {
    ++impl_->resets;
    MD_LOG(kWarn, "VIO reset at t_ns " << t_ns << ": odometry segment " << impl_->resets
                                       << " starts when it re-initializes (new world frame)");
  }
  if (!e.initialized) return std::nullopt;
  OdometrySample sample{e.T_world_body, std::nullopt, impl_->resets};
  return sample;
}

}  // namespace mapdelta::client
