#include "mapdelta/sim/options.hpp"

#include <cmath>
#include <functional>
#include <sstream>

#include "mapdelta/common/error.hpp"

namespace mapdelta::sim {
namespace {

// One row per option: name, help, how to print the current value, how to set it.
struct Option {
  std::string name;
  std::string help;
  std::function<std::string(const SimConfig&)> get;
  std::function<bool(SimConfig&, const std::string&)> set;
};

bool ToDouble(const std::string& s, double* v) {
  char* end = nullptr;
  *v = std::strtod(s.c_str(), &end);
  return !s.empty() && end == s.c_str() + s.size() && std::isfinite(*v);
}
bool ToInt(const std::string& s, long long* v) {
  char* end = nullptr;
  *v = std::strtoll(s.c_str(), &end, 10);
  return !s.empty() && end == s.c_str() + s.size();
}
std::string Fmt(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

#define MD_DOUBLE(field, text)                                                          \
  Option{#field, text, [](const SimConfig& c) { return Fmt(c.field); },                 \
         [](SimConfig& c, const std::string& s) { return ToDouble(s, &c.field); }}
#define MD_INT(field, text)                                                             \
  Option{#field, text, [](const SimConfig& c) { return std::to_string(c.field); },      \
         [](SimConfig& c, const std::string& s) {                                        \
           long long v;                                                                  \
           if (!ToInt(s, &v) || v < -1000000000LL || v > 1000000000LL) return false;     \
           c.field = static_cast<int>(v);                                                \
           return true;                                                                  \
         }}
#define MD_BOOL(field, text)                                                            \
  Option{#field, text + std::string(" (true/false)"),                                   \
         [](const SimConfig& c) { return std::string(c.field ? "true" : "false"); },    \
         [](SimConfig& c, const std::string& s) {                                        \
           if (s != "true" && s != "false" && s != "1" && s != "0") return false;        \
           c.field = s == "true" || s == "1";                                            \
           return true;                                                                  \
         }}

const std::vector<Option>& Options() {
  static const std::vector<Option> options = {
      Option{"seed", "random seed: same seed and options give byte-identical output",
             [](const SimConfig& c) { return std::to_string(c.seed); },
             [](SimConfig& c, const std::string& s) {
               long long v;
               if (!ToInt(s, &v) || v < 0) return false;
               c.seed = static_cast<uint64_t>(v);
               return true;
             }},
      Option{"noise", "sensor noise preset: none | small | big (paper table) | euroc (EuRoC IMU)",
             [](const SimConfig& c) { return std::string(ToString(c.noise)); },
             [](SimConfig& c, const std::string& s) { return ParseNoiseLevel(s, &c.noise); }},
      Option{"sequences", "comma-separated: S1_01,S1_02,S2_01,S2_02,S1_mirror,S1_dark",
             [](const SimConfig& c) {
               std::string s;
               for (const auto& q : c.sequences) s += (s.empty() ? "" : ",") + q;
               return s;
             },
             [](SimConfig& c, const std::string& s) {
               c.sequences.clear();
               std::stringstream in(s);
               for (std::string item; std::getline(in, item, ',');) {
                 if (!item.empty()) c.sequences.push_back(item);
               }
               return !c.sequences.empty();
             }},
      Option{"rig", "sensors: ideal (the camera options below) | euroc (EuRoC MH_01 cameras, lens, IMU axes)",
             [](const SimConfig& c) { return c.rig; },
             [](SimConfig& c, const std::string& s) {
               c.rig = s;
               return s == "ideal" || s == "euroc";
             }},
      MD_INT(threads, "worker threads for rendering (0 = all cores)"),
      MD_DOUBLE(extent_x, "scene size along x [m]"),
      MD_DOUBLE(extent_y, "scene size along y [m]"),
      MD_DOUBLE(min_height, "lowest building [m]"),
      MD_DOUBLE(max_height, "tallest building [m]"),
      MD_DOUBLE(block_size, "city block edge between streets [m]"),
      MD_DOUBLE(street_width, "street width incl. sidewalks [m]"),
      MD_INT(small_objects, "number of cars, trees, lamps, kiosks to place"),
      MD_DOUBLE(cloud_leaf, "voxel size of the ground-truth clouds [m]"),
      MD_INT(width, "image width [px]"),
      MD_INT(height, "image height [px]"),
      MD_DOUBLE(fx, "focal length x [px]"),
      MD_DOUBLE(fy, "focal length y [px]"),
      MD_DOUBLE(cx, "principal point x [px]"),
      MD_DOUBLE(cy, "principal point y [px]"),
      MD_DOUBLE(baseline, "stereo baseline [m]"),
      MD_DOUBLE(cam_rate_hz, "camera frame rate [Hz]"),
      MD_DOUBLE(imu_rate_hz, "IMU rate [Hz]"),
      MD_BOOL(write_depth, "write ground-truth depth of cam0 to depth0/"),
      MD_BOOL(shadows, "render sun shadows"),
      MD_DOUBLE(length_m, "trajectory length [m]"),
      MD_DOUBLE(duration_s, "trajectory duration [s]"),
      MD_DOUBLE(height_01, "flight height of *_01 sequences [m]"),
      MD_DOUBLE(height_02, "flight height of *_02 sequences [m]"),
      MD_DOUBLE(spline_spacing, "trajectory B-spline control point spacing [m] (larger = smoother turns)"),
  };
  return options;
}

}  // namespace

CliArgs ParseArgs(const std::vector<std::string>& args) {
  CliArgs out;
  std::vector<std::string> errors;
  // The preset sets the defaults; find it first so overrides apply on top, in any order.
  std::string preset = "tiny";
  for (size_t i = 0; i + 1 < args.size(); ++i) {
    if (args[i] == "--preset") preset = args[i + 1];
  }
  try {
    out.config = PresetConfig(preset);
  } catch (const Error& e) {
    errors.push_back(e.what());
  }
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--help" || a == "-h") { out.help = true; continue; }
    if (a == "--quiet") { out.quiet = true; continue; }
    if (a.rfind("--", 0) != 0) { errors.push_back("unexpected argument '" + a + "'"); continue; }
    const std::string name = a.substr(2);
    if (i + 1 >= args.size()) { errors.push_back(a + " needs a value"); continue; }
    const std::string value = args[++i];
    if (name == "preset") continue;
    if (name == "out") { out.out_dir = value; continue; }
    if (name == "log-level") { out.log_level = value; continue; }
    bool known = false;
    for (const Option& o : Options()) {
      if (o.name != name) continue;
      known = true;
      if (!o.set(out.config, value)) errors.push_back("--" + name + ": bad value '" + value + "'");
    }
    if (!known) errors.push_back("unknown option " + a + " (see --help)");
  }
  if (!out.help) {
    if (out.out_dir.empty()) errors.push_back("--out DIR is required");
    if (errors.empty()) {
      try {
        Validate(out.config);
      } catch (const Error& e) {
        errors.push_back(e.what());
      }
    }
  }
  if (!errors.empty()) {
    std::string msg;
    for (const auto& e : errors) msg += (msg.empty() ? "" : "\n") + e;
    throw Error(ErrorCode::kInvalidArgument, msg);
  }
  return out;
}

std::string HelpText(const std::string& preset) {
  const SimConfig c = PresetConfig(preset);
  const SimConfig paper = PresetConfig("paper");
  std::ostringstream o;
  o << "mapdelta-sim: generate the change-detection dataset (scenes original/S1/S2, stereo+IMU sequences)\n\n"
       "usage: mapdelta-sim --preset tiny|paper|euroc --out DIR [--seed N] [--noise none|small|big|euroc] [--<option> VALUE]...\n\n"
       "  --preset NAME       tiny (small scene, 400x225, ~25 s, for tests and the demo) or paper\n"
       "                      (250x250x40 m, 800x450, 30 Hz, ~700 m / 170 s, all six sequences) or euroc\n"
       "                      (EuRoC MH_01 sensors: 752x480 distorted stereo, 20 Hz, 200 Hz IMU; 12 s, S1_01)\n"
       "  --out DIR           output folder (layout: docs/conventions.md)\n"
       "  --log-level LEVEL   debug | info | warn | error | off (default info)\n"
       "  --quiet             no progress bar\n"
       "  --help              this text\n\n"
       "Every preset value can be overridden (default: tiny / paper):\n";
  for (const Option& opt : Options()) {
    std::string head = "  --" + opt.name + " V";
    head.resize(std::max<size_t>(head.size() + 1, 22), ' ');
    o << head << opt.help << " [" << opt.get(c) << " / " << opt.get(paper) << "]\n";
  }
  return o.str();
}

}  // namespace mapdelta::sim
