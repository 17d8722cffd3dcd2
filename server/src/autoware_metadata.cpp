// Autoware map metadata: parsed with yaml-cpp, written by hand (a flat mapping whose key order
// matters to readers of the file, which yaml-cpp's emitter would not make simpler).
#include "autoware_metadata.hpp"

#include <yaml-cpp/yaml.h>

#include <charconv>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/number_text.hpp"

namespace mapdelta::server {
namespace {

[[noreturn]] void Fail(const std::string& what, const std::string& message) {
  throw Error(ErrorCode::kParse, what + ": " + message);
}

double FiniteNumber(const YAML::Node& node, const std::string& what, const std::string& key) {
  double value = 0;
  if (!node.IsScalar() || !YAML::convert<double>::decode(node, value) || !std::isfinite(value)) {
    Fail(what, key + ": expected a finite number");
  }
  return value;
}

double Resolution(const YAML::Node& root, const std::string& what, const std::string& key) {
  const YAML::Node node = root[key];
  if (!node) Fail(what, key + ": missing (the tile size in metres)");
  const double value = FiniteNumber(node, what, key);
  if (!(value > 0)) Fail(what, key + ": expected a positive number of metres");
  return value;
}

// A tile file must stay inside the folder: a relative path without "..".
void CheckRelativeFile(const std::string& file, const std::string& what) {
  const std::filesystem::path path(file);
  if (path.is_absolute()) Fail(what, file + ": expected a file name relative to the folder");
  for (const auto& part : path) {
    if (part == "..") Fail(what, file + ": expected a file name inside the folder (no '..')");
  }
}

}  // namespace

std::string AutowareTileFileName(double x_min, double y_min) {
  return "pointcloud_map_" + ShortestNumber(x_min) + "_" + ShortestNumber(y_min) + ".pcd";
}

AutowareMetadata ParseAutowareMetadata(const std::string& text, const std::string& what) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    Fail(what, "not valid YAML: " + e.msg + " (line " + std::to_string(e.mark.line + 1) + ")");
  }
  if (!root.IsMap())
    Fail(what, "expected a mapping (x_resolution, y_resolution, FILE.pcd: [x, y])");
  AutowareMetadata metadata;
  metadata.x_resolution = Resolution(root, what, "x_resolution");
  metadata.y_resolution = Resolution(root, what, "y_resolution");
  for (const auto& entry : root) {
    if (!entry.first.IsScalar()) Fail(what, "expected file names as keys");
    const std::string key = entry.first.as<std::string>();
    if (key == "x_resolution" || key == "y_resolution") continue;
    const YAML::Node& corner = entry.second;
    if (!corner.IsSequence() || corner.size() != 2) {
      Fail(what, key + ": expected [x_min, y_min] (the tile's lower-left corner in metres)");
    }
    CheckRelativeFile(key, what);
    metadata.tiles.push_back({key, FiniteNumber(corner[0], what, key + "[0]"),
                              FiniteNumber(corner[1], what, key + "[1]")});
  }
  if (metadata.tiles.empty()) Fail(what, "no tile entries (FILE.pcd: [x_min, y_min])");
  return metadata;
}

std::string FormatAutowareMetadata(const AutowareMetadata& metadata) {
  std::ostringstream out;
  out << "x_resolution: " << ShortestNumber(metadata.x_resolution) << "\n"
      << "y_resolution: " << ShortestNumber(metadata.y_resolution) << "\n";
  for (const AutowareTileEntry& t : metadata.tiles) {
    out << t.file << ": [" << ShortestNumber(t.x_min) << ", " << ShortestNumber(t.y_min) << "]\n";
  }
  return out.str();
}

}  // namespace mapdelta::server
