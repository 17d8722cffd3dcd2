#pragma once
// Keyframes for the load driver, rendered once before the clock starts: the changed box scene of
// the server tests (tests/server/changed_scene.hpp) seen from cameras 8 m high driving along x
// in a few lanes, 160x90 analytic depth. A session loops over its lane's frames, so any number
// of keyframes costs a fixed amount of rendering; poses repeat, times only grow.
#include <string>
#include <vector>

#include "load_client.hpp"

namespace mapdelta::bench {

class KeyframeLanes {
 public:
  KeyframeLanes(int lanes, int frames_per_lane);
  int lanes() const { return static_cast<int>(png_.size()); }
  // The seq-th keyframe of a session in `lane` (t_ns = (seq + 1) s).
  MultipartKeyframe Keyframe(int lane, int seq) const;
  static std::string CameraJson();
  // The prior (box A and B, no C) as a PCD file for import-prior.
  static void WritePrior(const std::string& path);

 private:
  std::vector<std::vector<std::string>> png_;        // [lane][frame]
  std::vector<std::vector<std::string>> pose_json_;  // [lane][frame]
};

}  // namespace mapdelta::bench
