#include "mapdelta/client/vio_odometry_source.hpp"

#include <deque>
#include <map>
#include <mutex>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/vio/odometry.hpp"

namespace mapdelta::client {

struct VioOdometrySource::Impl {
  const StereoInput* input = nullptr;
  std::unique_ptr<vio::StereoInertialOdometry> vio;
  std::map<int64_t, StereoFrameFiles> frames;
  size_t next_imu = 0;
  int resets = 0;  // also the segment of the poses reported now
  std::mutex prepared_mutex;
  std::deque<vio::TrackedFrame> prepared;  // front-end output of frames At() has not reached
  // The last estimate and its gyro bias: after a reset (no estimates until the VIO
  // re-initializes) the last before the gap, which the first after it is bridged to.
  std::optional<GapEnd> last_estimate;
  Eigen::Vector3d last_gyro_bias = Eigen::Vector3d::Zero();
  bool bridge_pending = false;

  static vio::GrayImageView View(const GrayImage& image) {
    return {image.width, image.height, image.width, image.pixels.data()};
  }
  // The prepared frame at t_ns, if PrepareFrame ran for it (older ones were never asked).
  std::optional<vio::TrackedFrame> TakePrepared(int64_t t_ns) {
    std::lock_guard lock(prepared_mutex);
    while (!prepared.empty() && prepared.front().features.t_ns < t_ns) prepared.pop_front();
    if (prepared.empty() || prepared.front().features.t_ns != t_ns) return std::nullopt;
    vio::TrackedFrame f = std::move(prepared.front());
    prepared.pop_front();
    return f;
  }
};

VioOdometrySource::VioOdometrySource(const StereoInput& input, const VioSettings& settings)
    : impl_(std::make_unique<Impl>()) {
  impl_->input = &input;
  const EurocSequence& sequence = input.sequence();
  vio::VioConfig config;
  // The fusion's odometry factors use the configured sigmas (client/README.md, known limits):
  // the VIO's per-keyframe relative covariance (a Schur complement of the whole window, ~5 % of
  // its CPU at 800x450) would be computed for nothing.
  config.compute_keyframe_covariance = false;
  config.tracker.smooth_sigma_px = settings.smooth_sigma_px;
  impl_->vio = std::make_unique<vio::StereoInertialOdometry>(config, sequence.cam0, sequence.cam1,
                                                             sequence.imu);
  for (const auto& f : sequence.StereoFrames()) impl_->frames[f.t_ns] = f;
}

VioOdometrySource::~VioOdometrySource() = default;

int VioOdometrySource::resets() const { return impl_->resets; }

std::optional<OdometrySample> VioOdometrySource::At(int64_t t_ns, const StereoImages* images) {
  const auto it = impl_->frames.find(t_ns);
  if (it == impl_->frames.end()) return std::nullopt;
  // IMU up to and one past the frame time, as the VIO's API asks.
  const auto& imu = impl_->input->sequence().imu_samples;
  while (impl_->next_imu < imu.size()) {
    const bool past = imu[impl_->next_imu].t_ns > t_ns;
    impl_->vio->AddImu(imu[impl_->next_imu++]);
    if (past) break;
  }
  std::optional<vio::TrackedFrame> tracked = impl_->TakePrepared(t_ns);
  if (!tracked) {
    if (images != nullptr) {
      tracked = impl_->vio->TrackFrame(t_ns, Impl::View(images->left), Impl::View(images->right));
    } else {
      const GrayImage left = impl_->input->ReadLeft(it->second);
      const GrayImage right = impl_->input->ReadRight(it->second);
      tracked = impl_->vio->TrackFrame(t_ns, Impl::View(left), Impl::View(right));
    }
  }
  const vio::FrameEstimate e = impl_->vio->AddTrackedFrame(*tracked);
  if (e.reset) {
    impl_->bridge_pending = impl_->last_estimate.has_value();
    ++impl_->resets;
    MD_LOG(kWarn, "VIO reset at t_ns " << t_ns << ": odometry segment " << impl_->resets
                                       << " starts when it re-initializes (new world frame)");
  }
  if (!e.initialized) return std::nullopt;
  OdometrySample sample;
  sample.T_odom_body = e.T_world_body;
  sample.segment = impl_->resets;
  sample.v_odom = e.v_world;
  sample.gyro_bias = e.gyro_bias;
  const GapEnd here{t_ns, e.T_world_body, e.v_world};
  if (impl_->bridge_pending) {
    impl_->bridge_pending = false;
    sample.bridge =
        BridgeGap(*impl_->last_estimate, here, imu,
                  impl_->input->sequence().imu.T_body_imu.linear(), impl_->last_gyro_bias);
    MD_LOG(kInfo, "VIO re-initialized at t_ns "
                      << t_ns
                      << (sample.bridge ? ": bridged from the last pose before the reset by the IMU"
                                        : ": the IMU does not cover the gap, no bridge"));
  }
  impl_->last_estimate = here;
  impl_->last_gyro_bias = e.gyro_bias;
  return sample;
}

void VioOdometrySource::PrepareFrame(int64_t t_ns, const StereoImages& images) {
  if (impl_->frames.count(t_ns) == 0) return;
  vio::TrackedFrame f =
      impl_->vio->TrackFrame(t_ns, Impl::View(images.left), Impl::View(images.right));
  std::lock_guard lock(impl_->prepared_mutex);
  impl_->prepared.push_back(std::move(f));
}

}  // namespace mapdelta::client
