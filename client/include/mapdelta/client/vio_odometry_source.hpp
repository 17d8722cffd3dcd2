#pragma once
// The VIO (mapdelta_vio) behind the client's OdometrySource: feeds it the sequence's IMU
// samples and every stereo frame in time order, and reports its causal body pose per frame.
// Built only when mapdelta_vio is part of the build (library mapdelta_client_vio).
#include <memory>

#include "mapdelta/client/config.hpp"
#include "mapdelta/client/odometry_source.hpp"
#include "mapdelta/client/stereo_input.hpp"

namespace mapdelta::client {

class VioOdometrySource : public OdometrySource {
 public:
  // The input must outlive the source; the VIO runs on its rectified cameras, and `images`
  // given to At / PrepareFrame must be its rectified images (StereoInput::ReadLeft/ReadRight).
  VioOdometrySource(const StereoInput& input, const VioSettings& settings);
  ~VioOdometrySource() override;
  // Runs the VIO on the stereo frame at t_ns (`images`, or read through the input when null);
  // nullopt until it is initialized or when t_ns is not a stereo frame of the sequence. After
  // a VIO reset the odometry frame changes: the samples after it carry the next segment
  // number (OdometrySample::segment).
  std::optional<OdometrySample> At(int64_t t_ns, const StereoImages* images) override;
  bool NeedsImages() const override { return true; }
  bool GravityAligned() const override { return true; }
  // Runs the VIO's front end (feature tracking) on the frame; At(t_ns) then only estimates.
  // Either every frame is prepared or none.
  void PrepareFrame(int64_t t_ns, const StereoImages& images) override;
  int resets() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mapdelta::client
