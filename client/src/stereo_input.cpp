#include "mapdelta/client/stereo_input.hpp"

#include <opencv2/core.hpp>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/stereo_rectifier.hpp"

namespace mapdelta::client {

StereoInput::StereoInput(EurocSequence recorded)
    : sequence_(std::move(recorded)),
      rectifier_(MakeRectifierIfNeeded(sequence_.cam0, sequence_.cam1)) {
  if (rectifier_) {
    sequence_.cam0 = rectifier_->cam0();
    sequence_.cam1 = rectifier_->cam1();
  }
  rig_ = MakeRectifiedStereoRig(sequence_);
}

StereoInput::~StereoInput() = default;

GrayImage StereoInput::ReadLeft(const StereoFrameFiles& frame) const {
  return Read(0, frame.left_path);
}

GrayImage StereoInput::ReadRight(const StereoFrameFiles& frame) const {
  return Read(1, frame.right_path);
}

GrayImage StereoInput::Read(int camera, const std::string& path) const {
  GrayImage recorded = ReadGrayImage(path);
  if (!rectifier_) return recorded;
  const cv::Mat in(recorded.height, recorded.width, CV_8UC1, recorded.pixels.data());
  GrayImage out{recorded.width, recorded.height, std::vector<uint8_t>(recorded.pixels.size())};
  cv::Mat rectified(out.height, out.width, CV_8UC1, out.pixels.data());
  try {
    rectifier_->Rectify(camera, in, &rectified);
  } catch (const Error& e) {
    throw Error(e.code(), path + ": " + e.what());
  }
  return out;
}

}  // namespace mapdelta::client
