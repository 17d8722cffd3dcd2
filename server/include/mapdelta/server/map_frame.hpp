#pragma once
// The map's frame: which coordinates its users speak (a CRS name and an origin in them) and
// the local frame everything inside the server is in (user = local + origin; same axes, no
// rotation or scale). Stored once per map by the prior store, set by the first import.
#include <Eigen/Core>

#include <optional>
#include <string>

namespace mapdelta::server {

struct MapFrame {
  std::string crs;  // free text, e.g. "EPSG:32632"; empty: coordinates without a named CRS
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // in user coordinates, metres
};

// Points, poses and centroids are float32 in local coordinates (blob codec, octrees, GICP).
// A float32 in [-8192, 8192] m rounds by at most 2^-12 m (0.24 mm; measured on 200000 random
// mm-resolution UTM northings: 0.242 mm, against 250 mm for float32 of the northing itself);
// out to 16384 m by 0.49 mm, to 32768 m by 0.98 mm. The server refuses (never rounds
// silently) local coordinates beyond this bound, so every stored coordinate keeps its user
// value to a quarter of a millimetre, leaving the rest of the millimetre to float arithmetic
// (transforms, centroids).
constexpr double kMaxLocalCoordinateM = 8192;

// Same CRS text and origins within 1 micrometre (origins that went through text or a
// projection and back); 1 um shifts no stored float32 coordinate by more than rounding.
bool SameFrame(const MapFrame& a, const MapFrame& b);
// For the stores: throws Error(kConflict) naming both frames unless SameFrame.
void RequireSameFrame(const MapFrame& stored, const MapFrame& frame);
// "EPSG:32632, origin (500000, 5400000, 100)" or "no CRS, origin (0, 0, 0)", for errors.
std::string Describe(const MapFrame& frame);
// "(500000, 5400000, 100)".
std::string DescribeOrigin(const Eigen::Vector3d& origin);

// What an import asks for (CLI --origin/--crs, POST /v1/admin/prior ?origin=&crs=, an
// Autoware map_projector_info.yaml); a part not given is the map's, or chosen at the first
// import (the origin from the cloud: see MapService::ImportPriorFile).
struct FrameRequest {
  std::optional<std::string> crs;
  std::optional<Eigen::Vector3d> origin;
};
// "X,Y,Z" in metres (finite numbers); nullopt if malformed.
std::optional<Eigen::Vector3d> ParseOrigin(const std::string& text);

// A local float32 point in user coordinates (exact: a float32 fits a double).
inline Eigen::Vector3d UserPoint(const MapFrame& frame, const Eigen::Vector3f& local) {
  return local.cast<double>() + frame.origin;
}

}  // namespace mapdelta::server
