#include "mapdelta/client/pipeline.hpp"

#include <atomic>
#include <chrono>
#include <deque>
#include <exception>
#include <functional>
#include <optional>
#include <thread>
#include <vector>

#include "mapdelta/client/image.hpp"
#include "mapdelta/client/local_cloud.hpp"
#include "mapdelta/client/pose_fusion.hpp"
#include "mapdelta/client/prior_registration.hpp"
#include "mapdelta/client/stereo_depth.hpp"
#include "mapdelta/client/stereo_input.hpp"
#include "mapdelta/client/temporal_filter.hpp"
#include "mapdelta/common/bounded_queue.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/keyframes.hpp"
#include "mapdelta/common/lie.hpp"
#include "mapdelta/common/log.hpp"
#include "stage_timer.hpp"

namespace mapdelta::client {
namespace {

constexpr size_t kDecodedQueueCapacity = 4;  // ~0.7 MB per 800x450 stereo pair
constexpr size_t kKeyframeQueueCapacity = 4;
constexpr size_t kDepthQueueCapacity = 4;  // ~1.4 MB per 800x450 depth image
constexpr size_t kOutputQueueCapacity = 16;

struct DecodedFrame {
  const StereoFrameFiles* frame = nullptr;
  GrayImage left, right;
};

// A selected keyframe on its way to the depth stage, with its images when the odometry
// needed them decoded (empty otherwise: the depth stage reads them).
struct KeyframeImages {
  const StereoFrameFiles* frame = nullptr;
  OdometrySample odom;
  GrayImage left, right;
};

struct KeyframeDepth {
  int64_t t_ns = 0;
  OdometrySample odom;
  DepthImage raw;
};

struct FinalKeyframe {
  Keyframe keyframe;
};

// Captures the first exception of any stage so RunPipeline can rethrow it after joining.
struct Failure {
  std::mutex mutex;
  std::exception_ptr error;
  void Set(std::exception_ptr e) {
    std::lock_guard lock(mutex);
    if (!error) error = e;
  }
};

bool IsNewKeyframe(const SE3& last, int64_t last_t, const SE3& now, int64_t t,
                   const KeyframeSelectionConfig& c) {
  return (last.translation() - now.translation()).norm() >= c.min_translation_m ||
         RotationAngle(last, now) * 180.0 / M_PI >= c.min_rotation_deg ||
         (t - last_t) * 1e-9 >= c.max_interval_s;
}

// Stage B state: filter window, fusion, registration, finalization.
class Backend {
 public:
  Backend(const ClientConfig& config, const PipelineInputs& in, const StereoRig& rig,
          const SE3& initial_guess, StageTimer* timer, BoundedQueue<FinalKeyframe>* out,
          PipelineResult* result)
      : config_(config),
        rig_(rig),
        timer_(timer),
        out_(out),
        result_(result),
        fusion_(config.fusion),
        gravity_aligned_odometry_(in.odometry->GravityAligned()) {
    Matrix6 init_cov = Matrix6::Zero();
    init_cov.diagonal() << Eigen::Vector3d::Constant(std::pow(config.fusion.init_sigma_rot_rad, 2)),
        Eigen::Vector3d::Constant(std::pow(config.fusion.init_sigma_trans_m, 2));
    fusion_.SetInitialPose(initial_guess, init_cov);
    if (in.prior != nullptr) registrar_.emplace(config.registration, in.prior, in.num_threads);
  }

  void Add(KeyframeDepth kf) {
    raw_.push_back(std::move(kf));
    // Keyframe i is filtered once i + half_window has arrived.
    const size_t w = static_cast<size_t>(config_.temporal_filter.half_window);
    if (raw_.size() > w + filtered_in_window_) FilterNext();
  }

  void Finish() {
    while (filtered_in_window_ < raw_.size()) FilterNext();
    std::vector<std::optional<Matrix6>> covariances;
    {
      StageTimer::Scope t(timer_, "5 fusion (final pass)");
      const FusionSummary s = fusion_.Optimize(
          config_.fusion.final_iterations, Range(first_unemitted_, fusion_.size()), &covariances);
      MD_LOG(kInfo, "fusion final pass: " << s.iterations << " iterations, cost " << s.initial_cost
                                          << " -> " << s.final_cost << ", " << s.seconds << " s");
    }
    EmitFinal(fusion_.size(), covariances);
    for (size_t k = 0; k < fusion_.size(); ++k) {
      result_->vio_T_map_body.push_back({fusion_.t_ns(k), fusion_.OdometryInMap(k)});
      if (Placed(k)) result_->fused_T_map_body.push_back({fusion_.t_ns(k), fusion_.FusedPose(k)});
    }
    if (result_->keyframes_unplaced > 0) {
      MD_LOG(kWarn, result_->keyframes_unplaced
                        << " keyframes after odometry resets were never "
                           "re-anchored by a registration: not written or uploaded");
    }
  }

 private:
  // Filters the oldest unfiltered keyframe with its neighbours i-w..i+w in raw_.
  void FilterNext() {
    const size_t w = static_cast<size_t>(config_.temporal_filter.half_window);
    const size_t i = filtered_in_window_;
    std::vector<DepthFrame> frames;
    size_t center = 0;
    for (size_t j = (i >= w ? i - w : 0); j < std::min(raw_.size(), i + w + 1); ++j) {
      // Poses of another odometry segment are in an unrelated frame: not reprojectable.
      if (raw_[j].odom.segment != raw_[i].odom.segment) continue;
      if (j == i) center = frames.size();
      frames.push_back({raw_[j].odom.T_odom_body * rig_.T_body_cam0, &raw_[j].raw});
    }
    DepthImage filtered;
    std::optional<DepthImage> for_registration;  // only when its alpha differs
    {
      StageTimer::Scope t(timer_, "2 temporal filter");
      filtered = TemporalFilter(frames, center, rig_.left, config_.temporal_filter);
      if (config_.temporal_filter.registration_alpha != config_.temporal_filter.alpha) {
        TemporalFilterConfig strict = config_.temporal_filter;
        strict.alpha = strict.registration_alpha;
        for_registration = TemporalFilter(frames, center, rig_.left, strict);
      }
    }
    const KeyframeDepth& kf = raw_[i];
    const size_t k = fusion_.AddKeyframe(kf.t_ns, kf.odom.T_odom_body, kf.odom.rel_covariance,
                                         kf.odom.segment, kf.odom.bridge);
    if (k > 0 && fusion_.SegmentOf(k) != fusion_.SegmentOf(k - 1)) {
      ++result_->odometry_resets;
      since_cloud_ = 0;  // local clouds never mix segments
      MD_LOG(kWarn, "odometry segment " << kf.odom.segment << " starts at keyframe " << k
                                        << ": odometry chain broken, "
                                        << (kf.odom.bridge ? "bridged by the IMU"
                                                           : "predicted at constant velocity")
                                        << " until a registration re-anchors it");
    }
    filtered_.push_back(std::move(filtered));
    registration_depth_.push_back(std::move(for_registration));
    ++filtered_in_window_;
    // Raw depth older than the window is no longer needed.
    while (filtered_in_window_ > w) {
      raw_.pop_front();
      --filtered_in_window_;
    }
    const auto& lc = config_.local_cloud;
    if (++since_cloud_ ==
        static_cast<size_t>(lc.every_keyframes > 0 ? lc.every_keyframes : lc.keyframes)) {
      since_cloud_ = 0;
      Register(k);
    }
  }

  // Local cloud of the last N keyframes anchored at k, registered to the prior.
  void Register(size_t k) {
    if (!registrar_) return;
    size_t cloud_keyframes = 0;
    PointCloud local;
    {
      StageTimer::Scope t(timer_, "3 local cloud");
      local = GrowLocalCloud(k, &cloud_keyframes);
    }
    RegistrationOutcome r;
    const auto& rc = config_.registration;
    // A segment after an odometry reset is placed only by a constant-velocity guess: its first
    // local cloud is re-localized coarse-to-fine, as at start-up, with the wider limits.
    const bool reanchor = started_ && !fusion_.SegmentAnchored(k);
    const bool relocalize =
        started_ && (reanchor || rejected_in_row_ >= rc.relocalize_after_rejections);
    {
      StageTimer::Scope t(timer_, "4 registration");
      const SE3 guess = fusion_.FusedPose(k);
      // The body's up direction in the odometry frame: z up there when the source is a VIO.
      std::optional<Eigen::Vector3d> up;
      if (gravity_aligned_odometry_)
        up = fusion_.OdometryPose(k).linear().transpose() * Eigen::Vector3d::UnitZ();
      const double reloc_m = rc.relocalize_max_correction_m;
      const double reloc_rad = rc.relocalize_max_correction_deg * M_PI / 180.0;
      if (!started_) {
        r = registrar_->RefineInitialPose(local, guess, PriorRegistrar::kStartupMaxGuessErrorM,
                                          PriorRegistrar::kStartupMaxGuessErrorRad, up);
      } else if (reanchor) {
        r = registrar_->RefineAmongGuesses(local, ReanchorGuesses(k), reloc_m, reloc_rad, up);
      } else if (relocalize) {
        // Lost: odometry drifted beyond what the normal gate accepts. Search like at start-up.
        r = registrar_->RefineInitialPose(local, guess, reloc_m, reloc_rad, up);
      } else {
        r = registrar_->Register(local, guess, up);
      }
    }
    const char* mode = !started_    ? " (start-up)"
                       : reanchor   ? " (re-anchoring after an odometry reset)"
                       : relocalize ? " (re-localization)"
                                    : "";
    result_->registrations.push_back({fusion_.t_ns(k), k, r.accepted, r.reason, r.T_map_body,
                                      r.covariance, r.fitness_m, r.inlier_fraction, cloud_keyframes,
                                      local.size()});
    if (!r.accepted) {
      ++result_->registrations_rejected;
      ++rejected_in_row_;
      MD_LOG(kWarn, "registration of keyframe " << k << mode << " rejected: " << r.reason);
      return;
    }
    rejected_in_row_ = 0;
    ++result_->registrations_accepted;
    if (!started_) {
      MD_LOG(kInfo, "start-up pose refined by " << r.correction_m << " m, "
                                                << r.correction_rad * 180.0 / M_PI << " deg");
      started_ = true;
      result_->startup_refined = true;
    } else if (reanchor) {
      ++result_->segments_reanchored;
      MD_LOG(kInfo, "odometry segment re-anchored at keyframe "
                        << k << " at (" << r.T_map_body.translation().transpose() << "), "
                        << r.reason);
    } else if (relocalize) {
      MD_LOG(kInfo, "re-localized at keyframe " << k << " by " << r.correction_m << " m, "
                                                << r.correction_rad * 180.0 / M_PI << " deg");
    }
    // Keyframes that become final with this registration get their covariance from the same
    // solve.
    fusion_.AddRegistration(k, r.T_map_body, r.covariance);
    const long lag = config_.fusion.final_lag_keyframes;
    const long limit = std::min<long>(fusion_.LastRegisteredKeyframe() + 1,
                                      static_cast<long>(fusion_.size()) - lag);
    const size_t end =
        limit > static_cast<long>(first_unemitted_) ? static_cast<size_t>(limit) : first_unemitted_;
    std::vector<std::optional<Matrix6>> covariances;
    {
      StageTimer::Scope t(timer_, "5 fusion (incremental)");
      fusion_.Optimize(config_.fusion.incremental_iterations, Range(first_unemitted_, end),
                       &covariances);
    }
    EmitFinal(end, covariances);
  }

  // The local cloud of keyframes k-n+1..k, n = local_cloud.keyframes; when it has fewer than
  // local_cloud.min_points points (sparse stereo depth: a dark scene) it grows back over earlier
  // keyframes still buffered in k's odometry segment, up to local_cloud.max_keyframes. Why not
  // a lower inlier floor instead: 50 inliers is what keeps a 6-DoF solve from fitting noise,
  // while more keyframes of the same segment add real structure at the cost of some odometry
  // drift inside the cloud (1-2 % of the 10-20 m it spans).
  PointCloud GrowLocalCloud(size_t k, size_t* used) const {
    const auto& lc = config_.local_cloud;
    const size_t step = static_cast<size_t>(lc.keyframes);
    const size_t most = std::max(step, static_cast<size_t>(lc.max_keyframes));
    size_t n = step;
    PointCloud local = LocalCloudOf(k, n);
    while (local.size() < static_cast<size_t>(lc.min_points) && n < most) {
      const size_t wider = std::min(most, n + step);
      // Only keyframes still buffered (not yet emitted) and of k's segment.
      size_t first = k + 1 - std::min(k + 1, wider);
      first = std::max(first, first_unemitted_);
      while (first < k && fusion_.SegmentOf(first) != fusion_.SegmentOf(k)) ++first;
      if (k + 1 - first <= n) break;  // nothing more to add
      n = k + 1 - first;
      local = LocalCloudOf(k, n);
    }
    *used = n;
    return local;
  }

  // The local cloud of keyframes k-n+1..k (those still buffered) in k's odometry frame.
  PointCloud LocalCloudOf(size_t k, size_t n) const {
    std::vector<LocalCloudFrame> frames;
    for (size_t j = k + 1 - std::min(k + 1, n); j <= k; ++j) {
      if (j < first_unemitted_) continue;  // already handed downstream (only with odd configs)
      if (fusion_.SegmentOf(j) != fusion_.SegmentOf(k)) continue;  // another odometry frame
      const size_t q = j - first_unemitted_;
      frames.push_back({fusion_.OdometryPose(j),
                        registration_depth_[q] ? &*registration_depth_[q] : &filtered_[q]});
    }
    return BuildLocalCloud(frames, fusion_.OdometryPose(k), rig_.left, rig_.T_body_cam0,
                           config_.local_cloud);
  }

  // Hypotheses for keyframe k of a segment not yet anchored, carried from the segment start to
  // k by the segment's odometry. Bridged by the IMU, the start's heading is known and only its
  // distance along the gap is not (the speed in between was interpolated): the bridged pose
  // and the same heading at 3/4 and 1/2 of the way from the last fused pose. Otherwise: the
  // start at the constant-velocity prediction or at the last fused pose before the gap, each
  // turned about the vertical by evenly spaced headings.
  std::vector<SE3> ReanchorGuesses(size_t k) const {
    const size_t s0 = fusion_.SegmentStart(k);
    const SE3 along = fusion_.OdometryPose(s0).inverse() * fusion_.OdometryPose(k);
    std::vector<SE3> guesses;
    if (fusion_.SegmentBridged(k) && s0 > 0) {
      const SE3 bridged = fusion_.FusedPose(s0);
      const Eigen::Vector3d last = fusion_.FusedPose(s0 - 1).translation();
      for (double share : {1.0, 0.75, 0.5}) {
        SE3 start = bridged;
        start.translation() = last + share * (bridged.translation() - last);
        guesses.push_back(start * along);
      }
      return guesses;
    }
    std::vector<SE3> starts{fusion_.FusedPose(s0)};
    if (s0 > 0) starts.push_back(fusion_.FusedPose(s0 - 1));
    const int n = config_.registration.reanchor_yaw_hypotheses;
    for (int i = 0; i < n; ++i) {
      const Eigen::Matrix3d yaw =
          Eigen::AngleAxisd(2.0 * M_PI * i / n, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      for (const SE3& start : starts) {
        SE3 turned = start;
        turned.linear() = yaw * start.linear();
        guesses.push_back(turned * along);
      }
    }
    return guesses;
  }

  static std::vector<size_t> Range(size_t begin, size_t end) {
    std::vector<size_t> out;
    for (size_t k = begin; k < end; ++k) out.push_back(k);
    return out;
  }

  // Whether keyframe k has a pose in the map frame: the first odometry segment is placed by
  // the start-up pose; a segment after a reset only once a registration re-anchored it (before,
  // its pose is a constant-velocity guess across the gap).
  bool Placed(size_t k) const {
    return fusion_.SegmentOf(k) == fusion_.SegmentOf(0) || fusion_.SegmentAnchored(k);
  }

  // Sends keyframes [first_unemitted_, end) downstream with their fused poses; keyframes
  // without a map pose (not Placed) are dropped.
  void EmitFinal(size_t end, const std::vector<std::optional<Matrix6>>& covariances) {
    const size_t begin = first_unemitted_;
    while (first_unemitted_ < end) {
      if (!Placed(first_unemitted_)) {
        ++result_->keyframes_unplaced;
        filtered_.pop_front();
        registration_depth_.pop_front();
        ++first_unemitted_;
        continue;
      }
      FinalKeyframe f;
      const size_t i = first_unemitted_ - begin;
      if (i < covariances.size() && covariances[i]) {
        // Body covariance to camera: T_map_cam = T_map_body T_body_cam, right perturbations
        // transform by the adjoint of T_cam_body.
        const SE3 T_cam_body = rig_.T_body_cam0.inverse();
        const Eigen::Matrix3d R = T_cam_body.linear();
        Matrix6 Ad = Matrix6::Zero();
        Ad.topLeftCorner<3, 3>() = R;
        Ad.bottomRightCorner<3, 3>() = R;
        Ad.bottomLeftCorner<3, 3>() = -R * Skew(rig_.T_body_cam0.translation());
        f.keyframe.covariance = Ad * *covariances[i] * Ad.transpose();
      }
      f.keyframe.t_ns = fusion_.t_ns(first_unemitted_);
      f.keyframe.T_map_cam = fusion_.FusedPose(first_unemitted_) * rig_.T_body_cam0;
      f.keyframe.depth = std::move(filtered_.front());
      filtered_.pop_front();
      registration_depth_.pop_front();
      ++first_unemitted_;
      if (!out_->Push(std::move(f))) throw Error(ErrorCode::kInternal, "output queue closed");
    }
  }

  const ClientConfig& config_;
  const StereoRig& rig_;
  StageTimer* timer_;
  BoundedQueue<FinalKeyframe>* out_;
  PipelineResult* result_;
  PoseFusion fusion_;
  std::optional<PriorRegistrar> registrar_;
  std::deque<KeyframeDepth> raw_;    // unfiltered keyframes still needed by the filter window
  size_t filtered_in_window_ = 0;    // how many of raw_ are filtered already
  std::deque<DepthImage> filtered_;  // filtered depth of keyframes not yet emitted
  // The same keyframes filtered with registration_alpha (empty when it equals alpha).
  std::deque<std::optional<DepthImage>> registration_depth_;
  size_t first_unemitted_ = 0;
  const bool gravity_aligned_odometry_;  // registrations are checked against its gravity
  bool started_ = false;                 // start-up refinement accepted
  int rejected_in_row_ = 0;
  size_t since_cloud_ = 0;  // keyframes of the current segment since the last local cloud
};

// Everything the pipeline's threads share: the input, the queues between the stages, the
// stage timer, the first failure and the counters.
struct PipelineRun {
  PipelineRun(const ClientConfig& c, const PipelineInputs& i, const StereoInput& s,
              std::vector<StereoFrameFiles> f)
      : config(c),
        in(i),
        input(s),
        rig(s.rig()),
        frames(std::move(f)),
        decode_ahead(i.decode_ahead && i.odometry->NeedsImages()) {}
  const ClientConfig& config;
  const PipelineInputs& in;
  const StereoInput& input;
  const StereoRig& rig;
  const std::vector<StereoFrameFiles> frames;
  const bool decode_ahead;
  PipelineResult result;
  StageTimer timer;
  Failure failure;
  BoundedQueue<DecodedFrame> decoded_queue{kDecodedQueueCapacity};
  BoundedQueue<KeyframeImages> keyframe_queue{kKeyframeQueueCapacity};
  BoundedQueue<KeyframeDepth> depth_queue{kDepthQueueCapacity};
  BoundedQueue<FinalKeyframe> output_queue{kOutputQueueCapacity};
  std::atomic<size_t> frames_done{0}, keyframes{0};
};

// Stage 0 (only for odometry that uses the images): decodes every frame ahead of the
// odometry, once for it and the keyframe depth, and runs the odometry's frame-local part
// (the VIO's feature tracking). PNG decoding was ~13 % of the VIO thread, tracking ~35 %.
void DecodeStage(PipelineRun& run) {
  try {
    for (const auto& frame : run.frames) {
      DecodedFrame d{&frame, run.input.ReadLeft(frame), run.input.ReadRight(frame)};
      {
        StageTimer::Scope t(&run.timer, "0 odometry front end");
        run.in.odometry->PrepareFrame(frame.t_ns, StereoImages{d.left, d.right});
      }
      if (!run.decoded_queue.Push(std::move(d))) break;
    }
  } catch (...) {
    run.failure.Set(std::current_exception());
  }
  run.decoded_queue.Close();
}

// Stage A: frames -> odometry -> keyframe selection.
void KeyframeStage(PipelineRun& run) {
  try {
    std::optional<std::pair<int64_t, SE3>> last;
    int last_segment = 0;
    for (size_t i = 0; i < run.frames.size(); ++i) {
      std::optional<DecodedFrame> decoded;
      if (run.decode_ahead) {
        decoded = run.decoded_queue.Pop();
        if (!decoded) break;  // the decoder failed or the pipeline is shutting down
      }
      const StereoFrameFiles& frame = run.frames[i];
      ++run.frames_done;
      if (run.frames_done % 100 == 0) {
        MD_LOG(kInfo, "progress: frame " << run.frames_done << "/" << run.frames.size() << ", "
                                         << run.keyframes << " keyframes");
      }
      std::optional<OdometrySample> odom;
      {
        StageTimer::Scope t(&run.timer, "0 odometry");
        const std::optional<StereoImages> images =
            decoded ? std::optional<StereoImages>(StereoImages{decoded->left, decoded->right})
                    : std::nullopt;
        odom = run.in.odometry->At(frame.t_ns, images ? &*images : nullptr);
      }
      if (!odom) continue;
      // A new odometry segment (reset) always starts with a keyframe: its poses are not
      // comparable with the previous keyframe's.
      if (last && odom->segment == last_segment &&
          !IsNewKeyframe(last->second, last->first, odom->T_odom_body, frame.t_ns,
                         run.config.keyframes)) {
        continue;
      }
      last = {frame.t_ns, odom->T_odom_body};
      last_segment = odom->segment;
      KeyframeImages kf{&frame, *odom, {}, {}};
      if (decoded) {
        kf.left = std::move(decoded->left);
        kf.right = std::move(decoded->right);
      }
      ++run.keyframes;
      if (!run.keyframe_queue.Push(std::move(kf))) break;
    }
  } catch (...) {
    run.failure.Set(std::current_exception());
  }
  run.decoded_queue.Close();  // unblocks the decoder when this stage stops early
  run.keyframe_queue.Close();
}

// Stage A2: keyframe depth, on its own thread so the odometry never waits for SGBM.
void DepthStage(PipelineRun& run) {
  try {
    const StereoDepth stereo(run.config.stereo);
    while (auto kf = run.keyframe_queue.Pop()) {
      KeyframeDepth out{kf->frame->t_ns, kf->odom, {}};
      if (kf->left.pixels.empty()) kf->left = run.input.ReadLeft(*kf->frame);
      if (kf->right.pixels.empty()) kf->right = run.input.ReadRight(*kf->frame);
      {
        StageTimer::Scope t(&run.timer, "1 stereo depth");
        out.raw = stereo.ComputeDepth(kf->left, kf->right, run.rig);
      }
      if (!run.depth_queue.Push(std::move(out))) break;
    }
  } catch (...) {
    run.failure.Set(std::current_exception());
  }
  run.keyframe_queue.Close();
  run.depth_queue.Close();
}

// Stage C: keyframe folder + upload queue, without the band SGBM cannot match (see
// CropLeftBand; the uploader's session camera is KeyframeCamera(), the same crop).
void OutputStage(PipelineRun& run) {
  try {
    const int band = StereoDepth(run.config.stereo).UnmatchedBandFor(run.rig.left.width);
    const PinholeCamera out_camera = CropLeftBand(run.rig.left, band);
    while (auto f = run.output_queue.Pop()) {
      StageTimer::Scope t(&run.timer, "6 output + upload queue");
      f->keyframe.depth = CropLeftBand(f->keyframe.depth, band);
      if (!run.in.keyframe_dir.empty())
        AppendKeyframe(run.in.keyframe_dir, out_camera, run.config.upload.depth_scale, f->keyframe);
      if (run.in.uploader != nullptr) run.in.uploader->Enqueue(f->keyframe);
    }
  } catch (...) {
    run.failure.Set(std::current_exception());
    run.output_queue.Close();
  }
}

// The map pose of the first keyframe: the caller's guess, else the sequence's ground truth.
SE3 InitialGuess(const PipelineRun& run, int64_t t_ns) {
  SE3 guess;
  if (run.in.initial_T_map_body) return *run.in.initial_T_map_body;
  const Trajectory& groundtruth = run.input.sequence().groundtruth;
  if (!groundtruth.empty() && InterpolateAt(groundtruth, t_ns, &guess)) {
    MD_LOG(kWarn, "no initial pose given: using the sequence's ground truth at the first keyframe");
    return guess;
  }
  throw Error(ErrorCode::kInvalidArgument,
              "no initial pose given and the sequence has no ground truth to take it from");
}

// Stage B, on the caller's thread: filter, registration, fusion, finalization.
void BackendStage(PipelineRun& run) {
  try {
    std::optional<Backend> backend;
    while (auto kf = run.depth_queue.Pop()) {
      if (!backend) {
        backend.emplace(run.config, run.in, run.rig, InitialGuess(run, kf->t_ns), &run.timer,
                        &run.output_queue, &run.result);
      }
      backend->Add(std::move(*kf));
    }
    if (backend) backend->Finish();
  } catch (...) {
    run.failure.Set(std::current_exception());
    run.depth_queue.Close();
  }
  run.output_queue.Close();
  run.keyframe_queue.Close();  // after a backend failure: unblocks stages A and A2
  run.decoded_queue.Close();
}

}  // namespace

PinholeCamera KeyframeCamera(const ClientConfig& config, const PinholeCamera& left) {
  return CropLeftBand(left, StereoDepth(config.stereo).UnmatchedBandFor(left.width));
}

PipelineResult RunPipeline(const ClientConfig& config, const PipelineInputs& in) {
  if (in.odometry == nullptr)
    throw Error(ErrorCode::kInvalidArgument, "pipeline needs an odometry source");
  const auto wall_start = std::chrono::steady_clock::now();
  // Rectified once on input (distorted EuRoC pairs) for every stage below.
  std::optional<StereoInput> own_input;
  if (in.input == nullptr) own_input.emplace(ReadEurocSequence(in.sequence_dir));
  const StereoInput& input = in.input ? *in.input : *own_input;
  auto frames = input.sequence().StereoFrames();
  if (in.max_frames > 0 && frames.size() > static_cast<size_t>(in.max_frames))
    frames.resize(in.max_frames);
  if (frames.empty()) throw Error(ErrorCode::kNotFound, in.sequence_dir + ": no stereo frames");

  PipelineRun run(config, in, input, std::move(frames));
  std::thread stage_decode;
  if (run.decode_ahead) stage_decode = std::thread(DecodeStage, std::ref(run));
  std::thread stage_a(KeyframeStage, std::ref(run));
  std::thread stage_depth(DepthStage, std::ref(run));
  std::thread stage_c(OutputStage, std::ref(run));
  BackendStage(run);
  stage_a.join();
  stage_depth.join();
  if (stage_decode.joinable()) stage_decode.join();
  stage_c.join();
  if (run.failure.error) std::rethrow_exception(run.failure.error);

  PipelineResult result = std::move(run.result);
  result.frames = run.frames_done;
  result.keyframes = run.keyframes;
  result.timing = run.timer.Summary();
  result.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

}  // namespace mapdelta::client
