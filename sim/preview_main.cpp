// mapdelta-sim-preview: pictures of a generated city (top view with trajectories and changes,
// left image and colourized depth of chosen frames) without writing a dataset.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "mapdelta/common/error.hpp"
#include "mapdelta/sim/dataset_writer.hpp"
#include "mapdelta/sim/options.hpp"
#include "mapdelta/sim/preview.hpp"
#include "mapdelta/sim/raycaster.hpp"
#include "mapdelta/sim/sensor_rig.hpp"

namespace {

int RunPreview(const std::vector<std::string>& args) {
  using namespace mapdelta;
  using namespace mapdelta::sim;
  std::vector<double> times;
  const CliExtension preview{
      "mapdelta-sim-preview",
      "mapdelta-sim-preview: top views and sample frames of the simulated city. Writes "
      "OUT/top_S1.png,\n"
      "OUT/top_S2.png and for every --time T and sequence: OUT/<seq>_<T>_left.png, "
      "OUT/<seq>_<T>_depth.png.\n"
      "Takes every mapdelta-sim option (--preset, --seed, --sequences, --width, ...).",
      [&times](cli::Parser* p) { p->Repeated("time", &times, "frame time [s] (default 5)", "T"); }};
  const CliArgs parsed = ParseArgs(args, &preview);
  if (parsed.help) {
    std::cout << HelpText(&preview);
    return cli::kExitOk;
  }
  if (times.empty()) times.push_back(5.0);
  {
    const SimConfig& c = parsed.config;
    std::filesystem::create_directories(parsed.out_dir);
    const Scenes scenes = BuildScenes(c);
    for (const ChangedScene* cs : {&scenes.s1, &scenes.s2}) {
      std::vector<SequencePlan> plans;
      for (const std::string& name : c.sequences) {
        if (name.rfind(cs->scene.name + "_0", 0) == 0)
          plans.push_back(PlanSequence(c, scenes, name));
      }
      WriteTopView(parsed.out_dir + "/top_" + cs->scene.name + ".png", *cs, scenes.original, plans,
                   1000.0 / c.extent_x);
    }
    // cam0 of the configured rig (a distorted lens renders through its per-pixel rays).
    const SensorRig rig = MakeSensorRig(c);
    const PinholeCamera& cam = rig.cam[0].K;
    const std::vector<Eigen::Vector3f> rays =
        rig.cam[0].distortion.IsZero() ? std::vector<Eigen::Vector3f>{} : PixelRays(rig.cam[0]);
    for (const std::string& name : c.sequences) {
      const SequencePlan plan = PlanSequence(c, scenes, name);
      const Scene scene = RenderScene(plan);
      const EmbreeCaster caster(scene);
      for (double t : times) {
        const SE3 T = plan.trajectory.Evaluate(std::min(t, plan.duration_s)).T_map_body *
                      rig.T_vehicle_body * rig.cam[0].T_body_cam;
        RenderedView view;
        RenderViewInto(scene, caster, cam, T, {c.shadows, 3}, &view,
                       rays.empty() ? nullptr : &rays);
        char stem[256];
        std::snprintf(stem, sizeof(stem), "%s/%s_%05.1f", parsed.out_dir.c_str(), name.c_str(), t);
        WriteGreyPng(std::string(stem) + "_left.png", cam.width, cam.height, ToGrey8(view, 0.0, 0));
        WriteDepthColour(std::string(stem) + "_depth.png", view, 50.0);
      }
    }
  }
  return cli::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  return mapdelta::cli::RunMain("mapdelta-sim-preview", [&] { return RunPreview(args); });
}
