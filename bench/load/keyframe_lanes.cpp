#include "keyframe_lanes.hpp"

#include "changed_scene.hpp"
#include "mapdelta/common/cloud_io.hpp"

namespace mapdelta::bench {

namespace {
constexpr double kFirstLaneY = 25.0;  // as the server tests: boxes at y 10..15 in view
constexpr double kLaneSpacing = 2.0;
}  // namespace

KeyframeLanes::KeyframeLanes(int lanes, int frames_per_lane) {
  using namespace mapdelta::testing;
  const BoxScene scene = ChangedScene();
  for (int lane = 0; lane < lanes; ++lane) {
    png_.emplace_back();
    pose_json_.emplace_back();
    for (int f = 0; f < frames_per_lane; ++f) {
      const SE3 T =
          CameraLookingMinusY(-5.0 + f, kFirstLaneY + kLaneSpacing * lane, kCameraHeight, kPitch);
      png_.back().push_back(PngString(scene.Render(TestCamera(), T, kMaxDepth)));
      pose_json_.back().push_back(MetaJson(0, T)["T_map_cam"].dump());
    }
  }
}

MultipartKeyframe KeyframeLanes::Keyframe(int lane, int seq) const {
  const auto& frames = png_[lane % png_.size()];
  const size_t f = static_cast<size_t>(seq) % frames.size();
  const int64_t t_ns = 1000000000LL * (seq + 1);
  return {"{\"t_ns\":" + std::to_string(t_ns) +
              ",\"T_map_cam\":" + pose_json_[lane % png_.size()][f] + "}",
          frames[f]};
}

std::string KeyframeLanes::CameraJson() {
  const PinholeCamera c = testing::TestCamera();
  return nlohmann::json{{"width", c.width}, {"height", c.height}, {"fx", c.fx},
                        {"fy", c.fy},       {"cx", c.cx},         {"cy", c.cy}}
      .dump();
}

void KeyframeLanes::WritePrior(const std::string& path) {
  WriteCloud(path, testing::PriorScene().Sample(0.4));
}

}  // namespace mapdelta::bench
