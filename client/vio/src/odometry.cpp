#include "mapdelta/vio/odometry.hpp"

#include <chrono>
#include <deque>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/common/stereo_rectifier.hpp"
#include "mapdelta/vio/estimator.hpp"
#include "mapdelta/vio/feature_tracker.hpp"
#include "mapdelta/vio/initializer.hpp"

namespace mapdelta::vio {
namespace {

using Clock = std::chrono::steady_clock;
double MsSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

ImuSample Interpolate(const ImuSample& a, const ImuSample& b, int64_t t_ns) {
  if (b.t_ns <= a.t_ns) return {t_ns, b.gyro, b.accel};
  const double s = static_cast<double>(t_ns - a.t_ns) / static_cast<double>(b.t_ns - a.t_ns);
  return {t_ns, a.gyro + s * (b.gyro - a.gyro), a.accel + s * (b.accel - a.accel)};
}

void CheckRectified(const EurocCamera& cam0, const EurocCamera& cam1) {
  const SE3 T = cam0.T_body_cam.inverse() * cam1.T_body_cam;
  if (cam0.HasDistortion() || cam1.HasDistortion()) {
    throw Error(ErrorCode::kUnsupported, "vio: cameras have distortion; rectified input required");
  }
  if (RotationAngle(T, SE3::Identity()) > 1e-3 || T.translation().x() <= 0 ||
      std::hypot(T.translation().y(), T.translation().z()) > 1e-2 * T.translation().norm()) {
    throw Error(ErrorCode::kUnsupported, "vio: cam1 must sit at +x of cam0 with the same rotation");
  }
}

ImuNoiseDensities FlooredNoise(const VioConfig& c, ImuNoiseDensities n) {
  n.gyroscope_noise_density = std::max(n.gyroscope_noise_density, c.min_gyro_noise_density);
  n.accelerometer_noise_density =
      std::max(n.accelerometer_noise_density, c.min_accel_noise_density);
  n.gyroscope_random_walk = std::max(n.gyroscope_random_walk, c.min_gyro_random_walk);
  n.accelerometer_random_walk = std::max(n.accelerometer_random_walk, c.min_accel_random_walk);
  return n;
}

}  // namespace

StageTimes& StageTimes::operator+=(const StageTimes& o) {
  frontend_ms += o.frontend_ms;
  initialization_ms += o.initialization_ms;
  optimization_ms += o.optimization_ms;
  marginalization_ms += o.marginalization_ms;
  covariance_ms += o.covariance_ms;
  total_ms += o.total_ms;
  return *this;
}

struct StereoInertialOdometry::Impl {
  VioConfig config;
  EurocCamera cam0, cam1;
  ImuNoiseDensities noise;
  SE3 T_body_imu;
  StereoExtrinsics ext;  // relative to the IMU frame, in which the estimator runs
  FeatureTracker tracker;
  Initializer initializer;
  std::unique_ptr<SlidingWindowEstimator> estimator;
  std::deque<ImuSample> imu;
  std::optional<ImuSample> boundary;         // IMU interpolated at the previous frame time
  std::optional<int64_t> last_tracked_t_ns;  // front-end side of the frame-order check
  std::vector<KeyframeEstimate> finalized;
  StageTimes total;
  int frames = 0;
  std::unique_ptr<StereoRectifier> rectifier;  // set for distorted / non-parallel input pairs
  cv::Mat rectified[2];

  Impl(const VioConfig& c, const EurocCamera& c0, const EurocCamera& c1, const EurocImu& i)
      : config(c),
        cam0(c0),
        cam1(c1),
        noise(FlooredNoise(c, i.noise)),
        T_body_imu(i.T_body_imu),
        ext{i.T_body_imu.inverse() * c0.T_body_cam, i.T_body_imu.inverse() * c1.T_body_cam,
            c0.intrinsics.fx},
        tracker(c.tracker),
        initializer(c, ext) {}

  ImuPreintegration PreintegrateTo(int64_t t_ns) {
    ImuPreintegration pre(noise, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    // Interpolated sample at t_ns from the samples around it (hold the last if none after).
    std::optional<ImuSample> before, after;
    for (const auto& s : imu) {
      if (s.t_ns <= t_ns) before = s;
      if (s.t_ns >= t_ns) {
        after = s;
        break;
      }
    }
    ImuSample at_t;
    if (before && after)
      at_t = Interpolate(*before, *after, t_ns);
    else if (before)
      at_t = {t_ns, before->gyro, before->accel};
    else if (after)
      at_t = {t_ns, after->gyro, after->accel};
    else
      at_t = boundary ? ImuSample{t_ns, boundary->gyro, boundary->accel} : ImuSample{t_ns, {}, {}};
    if (boundary) {
      pre.Add(*boundary);
      for (const auto& s : imu) {
        if (s.t_ns > boundary->t_ns && s.t_ns < t_ns) pre.Add(s);
      }
      pre.Add(at_t);
    }
    boundary = at_t;
    while (imu.size() > 1 && imu[1].t_ns <= t_ns) imu.pop_front();
    return pre;
  }

  FrameFeatures Normalize(int64_t t_ns, const std::vector<TrackedFeature>& tracked) const {
    FrameFeatures f;
    f.t_ns = t_ns;
    const auto& k0 = cam0.intrinsics;
    const auto& k1 = cam1.intrinsics;
    for (const auto& t : tracked) {
      FeatureObservation o;
      o.id = t.id;
      o.left = {(t.left_px.x() - k0.cx) / k0.fx, (t.left_px.y() - k0.cy) / k0.fy};
      o.has_right = t.has_right;
      o.stereo_ambiguous = t.stereo_ambiguous;
      o.right = {(t.right_px.x() - k1.cx) / k1.fx, (t.right_px.y() - k1.cy) / k1.fy};
      f.features.push_back(o);
    }
    return f;
  }

  void Collect() {
    if (!estimator) return;
    for (auto& k : estimator->TakeFinalized()) {
      finalized.push_back(
          {k.t_ns, k.state.T_world_body * T_body_imu.inverse(), k.relative_covariance});
    }
  }
};

StereoInertialOdometry::StereoInertialOdometry(const VioConfig& config, const EurocCamera& cam0,
                                               const EurocCamera& cam1, const EurocImu& imu) {
  // Distorted or non-parallel pairs (real EuRoC) are rectified; the estimator then runs on the
  // rectified cameras.
  auto rectifier = MakeRectifierIfNeeded(cam0, cam1);
  const EurocCamera& c0 = rectifier ? rectifier->cam0() : cam0;
  const EurocCamera& c1 = rectifier ? rectifier->cam1() : cam1;
  CheckRectified(c0, c1);
  impl_ = std::make_unique<Impl>(config, c0, c1, imu);
  impl_->rectifier = std::move(rectifier);
}

StereoInertialOdometry::~StereoInertialOdometry() = default;

void StereoInertialOdometry::AddImu(const ImuSample& sample) {
  if (!impl_->imu.empty() && sample.t_ns <= impl_->imu.back().t_ns) return;
  impl_->imu.push_back(sample);
}

FrameEstimate StereoInertialOdometry::AddStereoFrame(int64_t t_ns, const GrayImageView& left,
                                                     const GrayImageView& right) {
  return AddTrackedFrame(TrackFrame(t_ns, left, right));
}

TrackedFrame StereoInertialOdometry::TrackFrame(int64_t t_ns, const GrayImageView& left,
                                                const GrayImageView& right) {
  Impl& m = *impl_;
  const auto t_start = Clock::now();
  if (!left.data || !right.data || left.width != right.width || left.height != right.height ||
      left.width != m.cam0.intrinsics.width || left.height != m.cam0.intrinsics.height) {
    throw Error(ErrorCode::kInvalidArgument, "vio: frame " + std::to_string(t_ns) +
                                                 ": images must both be " +
                                                 std::to_string(m.cam0.intrinsics.width) + "x" +
                                                 std::to_string(m.cam0.intrinsics.height));
  }
  if (m.last_tracked_t_ns && t_ns <= *m.last_tracked_t_ns) {
    throw Error(ErrorCode::kInvalidArgument, "vio: frame times must increase");
  }
  m.last_tracked_t_ns = t_ns;
  cv::Mat l(left.height, left.width, CV_8UC1, const_cast<uint8_t*>(left.data), left.stride_bytes);
  cv::Mat r(right.height, right.width, CV_8UC1, const_cast<uint8_t*>(right.data),
            right.stride_bytes);
  if (m.rectifier) {
    m.rectifier->Rectify(0, l, &m.rectified[0]);
    m.rectifier->Rectify(1, r, &m.rectified[1]);
    l = m.rectified[0];
    r = m.rectified[1];
  }
  TrackedFrame tracked;
  tracked.features = m.Normalize(t_ns, m.tracker.Track(l, r));
  tracked.frontend_ms = MsSince(t_start);
  return tracked;
}

FrameEstimate StereoInertialOdometry::AddTrackedFrame(const TrackedFrame& tracked) {
  Impl& m = *impl_;
  const auto t_start = Clock::now();
  const FrameFeatures& features = tracked.features;
  const int64_t t_ns = features.t_ns;
  FrameEstimate e;
  e.t_ns = t_ns;
  if (m.boundary && t_ns <= m.boundary->t_ns) {
    throw Error(ErrorCode::kInvalidArgument, "vio: frame times must increase");
  }
  e.features = static_cast<int>(features.features.size());
  e.times.frontend_ms = tracked.frontend_ms;
  const ImuPreintegration pre = m.PreintegrateTo(t_ns);
  ++m.frames;

  // 2. Initialization, or the sliding window.
  if (!m.estimator) {
    const auto t_init = Clock::now();
    auto init = m.initializer.AddFrame(features, pre);
    if (init) {
      m.estimator = std::make_unique<SlidingWindowEstimator>(m.config, m.ext);
      const std::optional<NavState> last = m.estimator->Start(std::move(*init));
      if (last) {
        e.initialized = true;
        e.T_world_body = last->T_world_body * m.T_body_imu.inverse();
        e.v_world = last->v_world;
        e.gyro_bias = last->bg;
        e.accel_bias = last->ba;
      } else {
        m.estimator.reset();
      }
    }
    e.times.initialization_ms = MsSince(t_init);
  } else {
    const EstimatorOutput out = m.estimator->AddFrame(features, pre);
    e.times.optimization_ms = out.optimize_ms;
    e.times.marginalization_ms = out.marginalize_ms;
    e.times.covariance_ms = out.covariance_ms;
    if (out.failed) {
      m.Collect();
      m.estimator.reset();
      m.initializer.Reset();
      e.reset = true;
    } else {
      e.initialized = true;
      e.keyframe = out.keyframe;
      e.T_world_body = out.state.T_world_body * m.T_body_imu.inverse();
      e.v_world = out.state.v_world;
      e.gyro_bias = out.state.bg;
      e.accel_bias = out.state.ba;
      e.landmarks = out.landmarks;
      e.relative_covariance = out.relative_covariance;
      m.Collect();
    }
  }
  e.times.total_ms = tracked.frontend_ms + MsSince(t_start);
  m.total += e.times;
  return e;
}

std::vector<KeyframeEstimate> StereoInertialOdometry::TakeFinalizedKeyframes() {
  std::vector<KeyframeEstimate> out;
  out.swap(impl_->finalized);
  return out;
}

void StereoInertialOdometry::Finish() {
  if (impl_->estimator) {
    impl_->estimator->Flush();
    impl_->Collect();
  }
}

const StageTimes& StereoInertialOdometry::accumulated_times() const { return impl_->total; }
int StereoInertialOdometry::frames() const { return impl_->frames; }

}  // namespace mapdelta::vio
