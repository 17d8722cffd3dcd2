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

int main(int argc, char** argv) {
  using namespace mapdelta;
  using namespace mapdelta::sim;
  std::vector<std::string> args(argv + 1, argv + argc), sim_args;
  std::vector<double> times;
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--help" || args[i] == "-h") {
      std::cout << "mapdelta-sim-preview: top views and sample frames of the simulated city\n\n"
                   "usage: mapdelta-sim-preview --out DIR [--time T]... [any mapdelta-sim option]\n"
                   "  --out DIR   writes DIR/top_S1.png, DIR/top_S2.png and for every --time T (seconds)\n"
                   "              and sequence: DIR/<seq>_<T>_left.png, DIR/<seq>_<T>_depth.png\n"
                   "  --time T    frame time (default 5); repeatable\n"
                   "  other options as mapdelta-sim (--preset, --seed, --sequences, --width, ...)\n";
      return 0;
    }
    if (args[i] == "--time" && i + 1 < args.size()) {
      try {
        times.push_back(std::stod(args[++i]));
      } catch (const std::exception&) {
        std::cerr << "mapdelta-sim-preview: bad --time '" << args[i] << "'\n";
        return 2;
      }
      continue;
    }
    sim_args.push_back(args[i]);
  }
  if (times.empty()) times.push_back(5.0);
  try {
    const CliArgs cli = ParseArgs(sim_args);
    const SimConfig& c = cli.config;
    std::filesystem::create_directories(cli.out_dir);
    const Scenes scenes = BuildScenes(c);
    for (const ChangedScene* cs : {&scenes.s1, &scenes.s2}) {
      std::vector<SequencePlan> plans;
      for (const std::string& name : c.sequences) {
        if (name.rfind(cs->scene.name + "_0", 0) == 0) plans.push_back(PlanSequence(c, scenes, name));
      }
      WriteTopView(cli.out_dir + "/top_" + cs->scene.name + ".png", *cs, scenes.original, plans, 1000.0 / c.extent_x);
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
        const SE3 T = plan.trajectory.Evaluate(std::min(t, plan.duration_s)).T_map_body * rig.T_vehicle_body *
                      rig.cam[0].T_body_cam;
        RenderedView view;
        RenderViewInto(scene, caster, cam, T, {c.shadows, 3}, &view, rays.empty() ? nullptr : &rays);
        char stem[256];
        std::snprintf(stem, sizeof(stem), "%s/%s_%05.1f", cli.out_dir.c_str(), name.c_str(), t);
        WriteGreyPng(std::string(stem) + "_left.png", cam.width, cam.height, ToGrey8(view, 0.0, 0));
        WriteDepthColour(std::string(stem) + "_depth.png", view, 50.0);
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "mapdelta-sim-preview: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
