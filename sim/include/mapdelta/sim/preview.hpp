#pragma once
// Pictures for humans: a top view of a scene with trajectories and the changes marked, and a
// colourized depth image. Colour PNGs written with OpenCV (kept out of this header).
#include <string>
#include <vector>

#include "mapdelta/sim/generator.hpp"
#include "mapdelta/sim/renderer.hpp"

namespace mapdelta::sim {

// Top view at `px_per_m`: ground by material, buildings shaded by height, removed buildings
// outlined in red, added ones in green, each trajectory as a coloured line (start marked).
void WriteTopView(const std::string& path, const ChangedScene& scene, const Scene& original,
                  const std::vector<SequencePlan>& plans, double px_per_m);
// Depth in [0, max_depth_m] as a colour map; no depth (sky) is black.
void WriteDepthColour(const std::string& path, const RenderedView& view, double max_depth_m);

}  // namespace mapdelta::sim
