#pragma once
// JSON <-> domain values for the API, with validation that names the offending field.
// Throws ApiError (kInvalidArgument / kInvalidPose).
#include <optional>
#include <string>
#include <string_view>

#include "mapdelta/common/camera.hpp"
#include "mapdelta/common/keyframes.hpp"
#include "mapdelta/common/pose.hpp"
#include "mapdelta/server/map_service.hpp"

namespace mapdelta::server {

// Request JSON (a body or a multipart part; `what` names it in errors): throws
// kInvalidJson when it is not JSON or nests deeper than kMaxJsonDepth. No request needs more
// than four levels; without a cap a 1 MiB body of '[' builds a document half a million levels
// deep, which every recursive walk (dump, compare, copy) would take down the stack.
constexpr int kMaxJsonDepth = 32;
Json ParseApiJson(std::string_view text, const std::string& what);

// {"width","height","fx","fy","cx","cy"}; checks ranges against the ingest limits.
PinholeCamera CameraFromJson(const Json& j, const IngestConfig& limits);
Json CameraToJson(const PinholeCamera& camera);
// Map coordinates beyond this are rejected before they reach voxel and tile arithmetic (integer
// indices): poses, bbox queries, prior points.
constexpr double kMaxCoordinate = 1e8;
// {"t":[x,y,z],"q":[qw,qx,qy,qz]}: finite, |t| <= kMaxCoordinate, |q| within 1e-3 of 1 (then
// normalized).
SE3 PoseFromJson(const Json& j, const std::string& field);
Json PoseToJson(const SE3& T);
// 36 finite numbers, symmetric within 1e-9 relative, non-negative diagonal; or null.
std::optional<Matrix6d> CovarianceFromJson(const Json& j, const std::string& field);

// Typed field access: throws kInvalidArgument "field 'x': expected ..." when missing/wrong.
const Json& Field(const Json& obj, const std::string& name);
double NumberField(const Json& obj, const std::string& name);
int64_t IntField(const Json& obj, const std::string& name);
std::string StringField(const Json& obj, const std::string& name);
void RejectUnknownFields(const Json& obj, std::initializer_list<const char*> known,
                         const std::string& where);

std::string IsoTime(int64_t ms);

}  // namespace mapdelta::server
