#pragma once
// Where the odometry comes from. The VIO (client/vio, mapdelta_vio) plugs in behind this
// interface; until then any trajectory file (TUM or EuRoC CSV, T_odom_body) feeds the fusion.
#include <Eigen/Core>
#include <optional>
#include <string>

#include "mapdelta/client/image.hpp"
#include "mapdelta/client/imu_gap_bridge.hpp"
#include "mapdelta/common/pose.hpp"

namespace mapdelta::client {

struct OdometrySample {
  SE3 T_odom_body = SE3::Identity();
  // Covariance of the motion since the previous sample asked for, if the source knows it.
  std::optional<Eigen::Matrix<double, 6, 6>> rel_covariance;
  // Odometry segment: increments whenever the odometry frame changes (a VIO reset and its
  // re-initialization in a new, arbitrary world frame). Poses of different segments are
  // unrelated: the client breaks its odometry chain there and re-localizes in the map.
  int segment = 0;
  // The velocity in the odometry frame and the gyro bias (IMU frame), when the source
  // estimates them (a VIO).
  std::optional<Eigen::Vector3d> v_odom, gyro_bias;
  // A segment's first sample: its pose in the previous segment's frame, bridged across the
  // gap by the IMU (imu_gap_bridge.hpp), when the source can.
  std::optional<OdometryBridge> bridge;
};

// A stereo frame already decoded (the pipeline decodes on its own thread, once for the
// odometry and the keyframe depth).
struct StereoImages {
  const GrayImage& left;
  const GrayImage& right;
};

class OdometrySource {
 public:
  virtual ~OdometrySource() = default;
  // The odometry pose at an image time; nullopt if the source has none (not initialized yet,
  // or outside the trajectory). Called with increasing t_ns. `images` is the frame at t_ns,
  // decoded, when NeedsImages() (else nullptr; a source needing them then reads them itself).
  virtual std::optional<OdometrySample> At(int64_t t_ns, const StereoImages* images) = 0;
  // Whether At() uses the frame's images: the pipeline then decodes every frame ahead.
  virtual bool NeedsImages() const { return false; }
  // Frame-local work that needs no earlier pose (a VIO's feature tracking), done ahead of
  // At(): with NeedsImages() the pipeline calls it on its decoding thread for every frame, in
  // order, up to a few frames before At(t_ns) runs on another thread.
  virtual void PrepareFrame(int64_t /*t_ns*/, const StereoImages& /*images*/) {}
  // Whether every segment's odometry frame has z up (gravity along -z), like the map: a VIO
  // measures gravity, and registrations tilted against it are then rejected
  // (RegistrationConfig::max_tilt_deg). A recorded trajectory may come from anywhere: false.
  virtual bool GravityAligned() const { return false; }
};

// A recorded trajectory, interpolated at the asked times. Throws Error naming the file.
class TrajectoryOdometrySource : public OdometrySource {
 public:
  explicit TrajectoryOdometrySource(const std::string& path);
  explicit TrajectoryOdometrySource(Trajectory trajectory);
  std::optional<OdometrySample> At(int64_t t_ns, const StereoImages* images) override;
  size_t size() const { return trajectory_.size(); }

 private:
  Trajectory trajectory_;
};

// Test and measurement fixture: another source with an injected odometry reset. From reset_t_ns
// on it reports no pose for gap_s seconds (the VIO re-initializing), then the inner poses
// re-expressed in another frame, T_new_old * T_odom_body (an arbitrary rigid transform, as a
// re-initialized VIO's world frame), in the next segment. The inner source is still asked at
// every time so its state advances as without the reset.
class InjectedResetOdometrySource : public OdometrySource {
 public:
  // With `imu` (the sequence's samples, outliving this) and an inner source that reports
  // velocity and gyro bias, the first sample after the gap carries the IMU bridge across it,
  // as a VIO's real reset does.
  InjectedResetOdometrySource(OdometrySource* inner, int64_t reset_t_ns, double gap_s,
                              const SE3& T_new_old, const std::vector<ImuSample>* imu = nullptr,
                              const Eigen::Matrix3d& R_body_imu = Eigen::Matrix3d::Identity());
  std::optional<OdometrySample> At(int64_t t_ns, const StereoImages* images) override;
  bool NeedsImages() const override { return inner_->NeedsImages(); }
  void PrepareFrame(int64_t t_ns, const StereoImages& images) override {
    inner_->PrepareFrame(t_ns, images);
  }
  // T_new_old may tilt the new frame: aligned only if it keeps z.
  bool GravityAligned() const override;

 private:
  OdometrySource* inner_;
  int64_t reset_t_ns_;
  int64_t gap_end_t_ns_;
  SE3 T_new_old_;
  const std::vector<ImuSample>* imu_;
  Eigen::Matrix3d R_body_imu_;
  std::optional<OdometrySample> last_before_;  // the last sample before the gap
  int64_t last_before_t_ns_ = 0;
};

}  // namespace mapdelta::client
