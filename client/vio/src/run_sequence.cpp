#include "mapdelta/vio/run_sequence.hpp"

#include <opencv2/imgcodecs.hpp>

#include <exception>
#include <thread>

#include "mapdelta/common/bounded_queue.hpp"
#include "mapdelta/common/error.hpp"

namespace mapdelta::vio {
namespace {

cv::Mat ReadGray(const std::string& path) {
  cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (image.empty()) throw Error(ErrorCode::kIo, path + ": cannot read image");
  return image;
}

GrayImageView View(const cv::Mat& m) { return {m.cols, m.rows, static_cast<int>(m.step), m.data}; }

TrackedFrame ReadAndTrack(StereoInertialOdometry* vio, const StereoFrameFiles& frame) {
  const cv::Mat left = ReadGray(frame.left_path);
  const cv::Mat right = ReadGray(frame.right_path);
  return vio->TrackFrame(frame.t_ns, View(left), View(right));
}

constexpr size_t kTrackedAhead = 4;  // frames the front-end thread may run ahead

}  // namespace

SequenceRunResult RunSequence(const EurocSequence& sequence, const VioConfig& config,
                              const SequenceRunOptions& options) {
  StereoInertialOdometry vio(config, sequence.cam0, sequence.cam1, sequence.imu);
  const auto frames = sequence.StereoFrames();
  const int total = options.max_frames > 0
                        ? std::min<int>(options.max_frames, static_cast<int>(frames.size()))
                        : static_cast<int>(frames.size());
  SequenceRunResult result;
  size_t imu_index = 0;
  const auto& imu = sequence.imu_samples;
  // The front end, on its own thread when pipelined.
  BoundedQueue<TrackedFrame> tracked(kTrackedAhead);
  std::exception_ptr frontend_error;
  std::thread frontend;
  if (options.pipelined) {
    frontend = std::thread([&] {
      try {
        for (int i = 0; i < total; ++i) {
          if (!tracked.Push(ReadAndTrack(&vio, frames[i]))) break;
        }
      } catch (...) {
        frontend_error = std::current_exception();
      }
      tracked.Close();
    });
  }
  struct JoinOnExit {
    std::thread* t;
    BoundedQueue<TrackedFrame>* q;
    ~JoinOnExit() {
      q->Close();
      if (t->joinable()) t->join();
    }
  } join_on_exit{&frontend, &tracked};
  for (int i = 0; i < total; ++i) {
    const auto& frame = frames[i];
    // Feed IMU up to the frame time plus one sample after it (for interpolation).
    while (imu_index < imu.size() && imu[imu_index].t_ns <= frame.t_ns)
      vio.AddImu(imu[imu_index++]);
    if (imu_index < imu.size()) vio.AddImu(imu[imu_index]);
    std::optional<TrackedFrame> f;
    if (options.pipelined) {
      f = tracked.Pop();
      if (!f) break;  // the front end failed: rethrown below
    } else {
      f = ReadAndTrack(&vio, frame);
    }
    const FrameEstimate e = vio.AddTrackedFrame(*f);
    ++result.processed;
    if (e.reset) {
      ++result.resets;
      result.reset_t_ns.push_back(e.t_ns);
    }
    if (e.initialized) {
      ++result.initialized;
      result.frames.push_back({e.t_ns, e.T_world_body});
    }
    if (options.on_frame) options.on_frame(i, total, e);
  }
  tracked.Close();
  if (frontend.joinable()) frontend.join();
  if (frontend_error) std::rethrow_exception(frontend_error);
  vio.Finish();
  for (const auto& k : vio.TakeFinalizedKeyframes()) {
    result.keyframes.push_back({k.t_ns, k.T_world_body});
    result.keyframe_covariances.push_back(k.relative_covariance);
  }
  result.times = vio.accumulated_times();
  if (total > 1)
    result.sequence_duration_s =
        1e-9 * static_cast<double>(frames[total - 1].t_ns - frames[0].t_ns);
  return result;
}

}  // namespace mapdelta::vio
