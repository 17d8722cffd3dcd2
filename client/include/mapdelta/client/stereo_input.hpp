#pragma once
// The recorded stereo sequence as every client stage sees it: rectified cameras and rectified
// images. A real EuRoC folder records distorted pairs from cameras ~1 degree from parallel;
// they are rectified once here, from the sequence's own calibration (sensor.yaml), and the VIO,
// stereo depth, temporal filter, local clouds and keyframes all run on the same rectified
// cameras. Sequences that already are a rectified pinhole pair (the simulator's) pass through
// untouched. No OpenCV in this header.
#include <memory>

#include "mapdelta/client/image.hpp"
#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/euroc.hpp"

namespace mapdelta {
class StereoRectifier;
}

namespace mapdelta::client {

class StereoInput {
 public:
  // Throws Error(kUnsupported) for a pair that cannot be rectified (a lens model other than
  // radial-tangential, cam1 not beside cam0: common/stereo_rectifier.hpp).
  explicit StereoInput(EurocSequence recorded);
  ~StereoInput();
  StereoInput(const StereoInput&) = delete;
  StereoInput& operator=(const StereoInput&) = delete;

  // The recorded sequence with cam0/cam1 replaced by the cameras the images of ReadLeft /
  // ReadRight are taken with (the rectified ones when rectifies()).
  const EurocSequence& sequence() const { return sequence_; }
  const StereoRig& rig() const { return rig_; }
  bool rectifies() const { return rectifier_ != nullptr; }
  // Decoded (ReadGrayImage) and rectified; safe to call from several threads.
  GrayImage ReadLeft(const StereoFrameFiles& frame) const;
  GrayImage ReadRight(const StereoFrameFiles& frame) const;

 private:
  GrayImage Read(int camera, const std::string& path) const;

  EurocSequence sequence_;
  std::unique_ptr<const StereoRectifier> rectifier_;
  StereoRig rig_;
};

}  // namespace mapdelta::client
