#include "api_json.hpp"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <set>

namespace mapdelta::server {

Json ParseApiJson(std::string_view text, const std::string& what) {
  // nlohmann's parser callback sees the nesting depth of every value as it is read (0 for the
  // outermost value), so the cap stops a deep document before it is built.
  const auto cap_depth = [&what](int depth, Json::parse_event_t, Json&) {
    if (depth >= kMaxJsonDepth) {
      throw ApiError(ApiCode::kInvalidJson,
                     what + " nests deeper than " + std::to_string(kMaxJsonDepth) + " levels");
    }
    return true;
  };
  try {
    return Json::parse(text.begin(), text.end(), cap_depth);
  } catch (const Json::parse_error& e) {
    throw ApiError(ApiCode::kInvalidJson, what + " is not valid JSON: " + e.what());
  }
}

const Json& Field(const Json& obj, const std::string& name) {
  if (!obj.is_object()) throw ApiError(ApiCode::kInvalidArgument, "expected a JSON object");
  auto it = obj.find(name);
  if (it == obj.end()) throw ApiError(ApiCode::kInvalidArgument, "field '" + name + "' is missing");
  return *it;
}

double NumberField(const Json& obj, const std::string& name) {
  const Json& v = Field(obj, name);
  if (!v.is_number())
    throw ApiError(ApiCode::kInvalidArgument, "field '" + name + "': expected a number");
  const double d = v.get<double>();
  if (!std::isfinite(d))
    throw ApiError(ApiCode::kInvalidArgument, "field '" + name + "': not finite");
  return d;
}

int64_t IntField(const Json& obj, const std::string& name) {
  const Json& v = Field(obj, name);
  if (!v.is_number_integer()) {
    throw ApiError(ApiCode::kInvalidArgument, "field '" + name + "': expected an integer");
  }
  return v.get<int64_t>();
}

std::string StringField(const Json& obj, const std::string& name) {
  const Json& v = Field(obj, name);
  if (!v.is_string())
    throw ApiError(ApiCode::kInvalidArgument, "field '" + name + "': expected a string");
  return v.get<std::string>();
}

void RejectUnknownFields(const Json& obj, std::initializer_list<const char*> known,
                         const std::string& where) {
  if (!obj.is_object())
    throw ApiError(ApiCode::kInvalidArgument, where + ": expected a JSON object");
  const std::set<std::string> names(known.begin(), known.end());
  for (auto it = obj.begin(); it != obj.end(); ++it) {
    if (!names.count(it.key())) {
      throw ApiError(ApiCode::kInvalidArgument, where + ": unknown field '" + it.key() + "'");
    }
  }
}

PinholeCamera CameraFromJson(const Json& j, const IngestConfig& limits) {
  RejectUnknownFields(j, {"width", "height", "fx", "fy", "cx", "cy"}, "camera");
  PinholeCamera c;
  // Range-checked before narrowing to int (2^32 + 160 must not become 160).
  const int64_t width = IntField(j, "width"), height = IntField(j, "height");
  c.fx = NumberField(j, "fx");
  c.fy = NumberField(j, "fy");
  c.cx = NumberField(j, "cx");
  c.cy = NumberField(j, "cy");
  if (width < 1 || width > limits.max_image_width || height < 1 ||
      height > limits.max_image_height) {
    throw ApiError(ApiCode::kInvalidArgument,
                   "camera: width/height must be in [1, " + std::to_string(limits.max_image_width) +
                       "] x [1, " + std::to_string(limits.max_image_height) + "]");
  }
  c.width = static_cast<int>(width);
  c.height = static_cast<int>(height);
  try {
    c.Validate();
  } catch (const std::exception& e) {
    throw ApiError(ApiCode::kInvalidArgument, std::string("camera: ") + e.what());
  }
  return c;
}

Json CameraToJson(const PinholeCamera& c) {
  return Json{{"width", c.width}, {"height", c.height}, {"fx", c.fx},
              {"fy", c.fy},       {"cx", c.cx},         {"cy", c.cy}};
}

SE3 PoseFromJson(const Json& j, const std::string& field) {
  if (!j.is_object() || !j.contains("t") || !j.contains("q") || !j["t"].is_array() ||
      !j["q"].is_array() || j["t"].size() != 3 || j["q"].size() != 4) {
    throw ApiError(ApiCode::kInvalidArgument,
                   "field '" + field + "': expected {\"t\":[x,y,z], \"q\":[qw,qx,qy,qz]}");
  }
  double v[7];
  for (int i = 0; i < 7; ++i) {
    const Json& e = i < 3 ? j["t"][i] : j["q"][i - 3];
    // NaN/inf cannot be written in strict JSON; clients that send null or strings for them
    // end up here too.
    if (!e.is_number() || !std::isfinite(e.get<double>())) {
      throw ApiError(ApiCode::kInvalidPose,
                     "field '" + field + "': non-finite or non-numeric entry");
    }
    v[i] = e.get<double>();
  }
  // Found by fuzz_keyframe_meta: t = 2e35 reached the voxel filter's double -> int64 cast.
  if (std::max({std::abs(v[0]), std::abs(v[1]), std::abs(v[2])}) > kMaxCoordinate) {
    throw ApiError(ApiCode::kInvalidPose,
                   "field '" + field + ".t': coordinates must be within +-1e8 m");
  }
  Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
  if (std::abs(q.norm() - 1.0) > 1e-3) {
    throw ApiError(ApiCode::kInvalidPose, "field '" + field + ".q': quaternion norm " +
                                              std::to_string(q.norm()) + " is not 1 (within 1e-3)");
  }
  q.normalize();
  return MakeSE3(q, Eigen::Vector3d(v[0], v[1], v[2]));
}

Json PoseToJson(const SE3& T) {
  const Eigen::Quaterniond q(T.rotation());
  const Eigen::Vector3d t = T.translation();
  return Json{{"t", {t.x(), t.y(), t.z()}}, {"q", {q.w(), q.x(), q.y(), q.z()}}};
}

std::optional<Matrix6d> CovarianceFromJson(const Json& j, const std::string& field) {
  if (j.is_null()) return std::nullopt;
  if (!j.is_array() || j.size() != 36) {
    throw ApiError(ApiCode::kInvalidPose, "field '" + field + "': expected 36 numbers or null");
  }
  Matrix6d m;
  for (int i = 0; i < 36; ++i) {
    if (!j[i].is_number() || !std::isfinite(j[i].get<double>())) {
      throw ApiError(ApiCode::kInvalidPose,
                     "field '" + field + "': non-finite entry " + std::to_string(i));
    }
    m(i / 6, i % 6) = j[i].get<double>();
  }
  const double scale = std::max(1e-300, m.cwiseAbs().maxCoeff());
  if ((m - m.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) {
    throw ApiError(ApiCode::kInvalidPose, "field '" + field + "': not symmetric");
  }
  if ((m.diagonal().array() < 0).any()) {
    throw ApiError(ApiCode::kInvalidPose,
                   "field '" + field + "': negative variance on the diagonal");
  }
  return m;
}

std::string IsoTime(int64_t ms) {
  const std::time_t s = static_cast<std::time_t>(ms / 1000);
  std::tm tm{};
  gmtime_r(&s, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%S", &tm);
  char out[40];
  std::snprintf(out, sizeof(out), "%s.%03dZ", buf, static_cast<int>(ms % 1000));
  return out;
}

}  // namespace mapdelta::server
