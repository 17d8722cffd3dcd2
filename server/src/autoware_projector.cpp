// map_projector_info.yaml: parsed with yaml-cpp, written by hand (three keys).
#include "autoware_projector.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/number_text.hpp"

namespace mapdelta::server {

FrameRequest ParseAutowareProjector(const std::string& text, const std::string& path) {
  const auto fail = [&](const std::string& message) -> Error {
    return Error(ErrorCode::kParse, path + ": " + message);
  };
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw fail(std::string("not YAML: ") + e.what());
  }
  if (!root.IsMap()) throw fail("expected a mapping with projector_type");
  const YAML::Node type = root["projector_type"];
  if (!type || !type.IsScalar()) throw fail("projector_type: missing");
  const std::string name = type.as<std::string>();
  if (name != "Local" && name != "local") {
    throw Error(ErrorCode::kUnsupported,
                path + ": projector_type '" + name +
                    "' is not supported (Local only, optionally with mapdelta_frame: geodetic "
                    "projections need lat/lon to UTM); import the tiles with --origin instead");
  }
  FrameRequest request;
  const YAML::Node frame = root["mapdelta_frame"];
  if (!frame) return request;
  if (!frame.IsMap()) throw fail("mapdelta_frame: expected {crs, origin: [x, y, z]}");
  if (frame["crs"]) {
    if (!frame["crs"].IsScalar()) throw fail("mapdelta_frame.crs: expected a string");
    request.crs = frame["crs"].as<std::string>();
  }
  const YAML::Node origin = frame["origin"];
  if (!origin || !origin.IsSequence() || origin.size() != 3)
    throw fail("mapdelta_frame.origin: expected [x, y, z]");
  Eigen::Vector3d o;
  for (int a = 0; a < 3; ++a) {
    if (!origin[a].IsScalar() || !YAML::convert<double>::decode(origin[a], o[a]) ||
        !std::isfinite(o[a]))
      throw fail("mapdelta_frame.origin: expected three finite numbers");
  }
  request.origin = o;
  return request;
}

std::string FormatAutowareProjector(const MapFrame& frame) {
  std::string out =
      "# Written by mapdelta-server export-autoware. The tiles hold the map's local\n"
      "# coordinates; in the map's CRS a point is at local + mapdelta_frame.origin.\n"
      "projector_type: Local\n";
  if (frame.crs.empty() && frame.origin.isZero(0)) return out;
  out += "mapdelta_frame:\n  crs: \"" + frame.crs + "\"\n  origin: [" +
         ShortestNumber(frame.origin.x()) + ", " + ShortestNumber(frame.origin.y()) + ", " +
         ShortestNumber(frame.origin.z()) + "]\n";
  return out;
}

}  // namespace mapdelta::server
