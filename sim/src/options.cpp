#include "mapdelta/sim/options.hpp"

#include <cmath>
#include <functional>
#include <map>
#include <sstream>

#include "mapdelta/common/cli.hpp"
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

#define MD_DOUBLE(field, text)                                                                    \
  Option {                                                                                        \
#field, text,                                                                                 \
        [](const SimConfig& c) { return Fmt(c.field); },                                          \
                                                      [](SimConfig & c,                           \
                                                         const std::string&                       \
                                                             s) { return ToDouble(s, &c.field); } \
  }
#define MD_INT(field, text)                                                      \
  Option {                                                                       \
#field, text, [](const SimConfig& c) { return std::to_string(c.field); },      \
         [](SimConfig& c, const std::string& s) {                                        \
           long long v;                                                                  \
           if (!ToInt(s, &v) || v < -1000000000LL || v > 1000000000LL) return false;     \
           c.field = static_cast<int>(v);                                                \
           return true;                                                                  \
         } \
  }
#define MD_BOOL(field, text)                                                     \
  Option {                                                                       \
#field, text + std::string(" (true/false)"),                                   \
         [](const SimConfig& c) { return std::string(c.field ? "true" : "false"); },    \
         [](SimConfig& c, const std::string& s) {                                        \
           if (s != "true" && s != "false" && s != "1" && s != "0") return false;        \
           c.field = s == "true" || s == "1";                                            \
           return true;                                                                  \
         } \
  }

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
      Option{
          "rig",
          "sensors: ideal (the camera options below) | euroc (EuRoC MH_01 cameras, lens, IMU axes)",
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
      MD_DOUBLE(spline_spacing,
                "trajectory B-spline control point spacing [m] (larger = smoother turns)"),
  };
  return options;
}

// Declares mapdelta-sim's options: the fixed ones, and every SimConfig field as a string
// that ParseArgs applies on top of the preset (so the order on the command line does not matter).
void DeclareOptions(cli::Parser* cli, CliArgs* out, std::string* preset,
                    std::map<std::string, std::string>* values) {
  cli->Option("preset", preset,
              "tiny (small scene, 400x225, ~25 s, for tests and the demo) or paper (250x250x40 m, "
              "800x450, "
              "30 Hz, ~700 m / 170 s, all six sequences) or euroc (EuRoC MH_01 sensors: 752x480 "
              "distorted "
              "stereo, 20 Hz, 200 Hz IMU; 12 s, S1_01)",
              "NAME")
      .Choices("preset", {"tiny", "paper", "euroc"})
      .Option("out", &out->out_dir, "output folder (layout: docs/conventions.md), required", "DIR")
      .Option("log-level", &out->log_level, "log level")
      .Choices("log-level", {"debug", "info", "warn", "error", "off"})
      .Flag("quiet", &out->quiet, "no progress bar");
  const SimConfig tiny = PresetConfig("tiny");
  const SimConfig paper = PresetConfig("paper");
  for (const Option& o : Options()) {
    cli->Option(o.name, &(*values)[o.name],
                o.help + " [tiny " + o.get(tiny) + " / paper " + o.get(paper) + "]", "V");
  }
  cli->Footer(
      "Every preset value can be overridden; [defaults] are the tiny and paper presets'.\n" +
      std::string(cli::kExitCodesFooter));
}

constexpr const char* kProgram = "mapdelta-sim";
constexpr const char* kDescription =
    "mapdelta-sim: generate the change-detection dataset (scenes original/S1/S2, stereo+IMU "
    "sequences).\n"
    "'mapdelta-sim renoise --help': new sensor noise on a clean dataset.";

}  // namespace

CliArgs ParseArgs(const std::vector<std::string>& args, const CliExtension* extension) {
  CliArgs out;
  std::string preset = "tiny";
  std::map<std::string, std::string> values;
  const std::string program = extension ? extension->program : kProgram;
  cli::Parser cli(program, extension ? extension->description : kDescription);
  DeclareOptions(&cli, &out, &preset, &values);
  if (extension) extension->declare(&cli);
  std::ostringstream help;  // main prints HelpText()
  if (!cli.Parse(args, help)) {
    out.help = true;
    return out;
  }
  // Values on top of the preset, every bad one reported at once.
  out.config = PresetConfig(preset);
  std::vector<std::string> errors;
  for (const Option& o : Options()) {
    if (cli.Given(o.name) && !o.set(out.config, values[o.name])) {
      errors.push_back("--" + o.name + ": bad value '" + values[o.name] + "'");
    }
  }
  if (out.out_dir.empty()) errors.push_back("missing --out");
  if (errors.empty()) {
    try {
      Validate(out.config);
    } catch (const Error& e) {
      errors.push_back(e.what());
    }
  }
  if (!errors.empty()) {
    std::string msg;
    for (const auto& e : errors) msg += (msg.empty() ? "" : "\n") + e;
    cli::FailUsage(program, msg);
  }
  return out;
}

std::string HelpText(const CliExtension* extension) {
  CliArgs out;
  std::string preset;
  std::map<std::string, std::string> values;
  cli::Parser cli(extension ? extension->program : kProgram,
                  extension ? extension->description : kDescription);
  DeclareOptions(&cli, &out, &preset, &values);
  if (extension) extension->declare(&cli);
  return cli.Help();
}

}  // namespace mapdelta::sim
