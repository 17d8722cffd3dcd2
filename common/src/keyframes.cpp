#include "mapdelta/common/keyframes.hpp"

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/trajectory_io.hpp"

namespace mapdelta {
namespace fs = std::filesystem;
namespace {

void WriteCameraYaml(const std::string& path, const PinholeCamera& camera, double depth_scale) {
  std::ofstream out(path);
  out << std::setprecision(17) << "width: " << camera.width << "\nheight: " << camera.height
      << "\nfx: " << camera.fx << "\nfy: " << camera.fy << "\ncx: " << camera.cx
      << "\ncy: " << camera.cy << "\ndepth_scale: " << depth_scale << "\n";
  if (!out) throw Error(ErrorCode::kIo, path + ": cannot write");
}

void ReadCameraYaml(const std::string& path, PinholeCamera* camera, double* depth_scale) {
  YAML::Node node;
  try {
    node = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw Error(ErrorCode::kIo, path + ": missing (every keyframe folder needs camera.yaml)");
  } catch (const YAML::Exception& e) {
    throw Error(ErrorCode::kParse, path + ": " + e.what());
  }
  const auto field = [&](const char* key) {
    if (!node[key]) throw Error(ErrorCode::kParse, path + ": missing field '" + key + "'");
    try {
      return node[key].as<double>();
    } catch (const YAML::Exception&) {
      throw Error(ErrorCode::kParse, path + ": field '" + key + "' must be a number");
    }
  };
  camera->width = static_cast<int>(field("width"));
  camera->height = static_cast<int>(field("height"));
  camera->fx = field("fx");
  camera->fy = field("fy");
  camera->cx = field("cx");
  camera->cy = field("cy");
  *depth_scale = node["depth_scale"] ? field("depth_scale") : kDefaultDepthScale;
  try {
    camera->Validate();
  } catch (const Error& e) {
    throw Error(ErrorCode::kParse, path + ": " + e.what());
  }
}

std::map<int64_t, Matrix6d> ReadCovariances(const std::string& path) {
  std::map<int64_t, Matrix6d> out;
  std::ifstream in(path);
  if (!in) return out;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    int64_t t_ns = 0;
    Matrix6d c;
    fields >> t_ns;
    for (int i = 0; i < 36; ++i) fields >> c.data()[i];
    if (!fields || !c.allFinite()) {
      throw Error(ErrorCode::kParse,
                  path + ":" + std::to_string(n) + ": expected t_ns and 36 numbers");
    }
    out[t_ns] = c.transpose();  // file is row-major, Eigen is column-major
  }
  return out;
}

void AppendCovariance(const std::string& path, int64_t t_ns, const Matrix6d& c) {
  std::ofstream out(path, std::ios::app);
  out << t_ns << std::setprecision(12);
  for (int r = 0; r < 6; ++r)
    for (int k = 0; k < 6; ++k) out << ' ' << c(r, k);
  out << '\n';
  if (!out) throw Error(ErrorCode::kIo, path + ": cannot append");
}

void AppendPose(const std::string& path, const Keyframe& keyframe) {
  const bool is_new = !fs::exists(path);
  std::ofstream out(path, std::ios::app);
  if (is_new) out << "# t x y z qx qy qz qw  (T_map_cam)\n";
  const Eigen::Quaterniond q(keyframe.T_map_cam.linear());
  const Eigen::Vector3d& t = keyframe.T_map_cam.translation();
  out << keyframe.t_ns / 1000000000 << '.' << std::setw(9) << std::setfill('0')
      << keyframe.t_ns % 1000000000 << std::setfill(' ') << std::setprecision(9) << std::fixed
      << ' ' << t.x() << ' ' << t.y() << ' ' << t.z() << ' ' << q.x() << ' ' << q.y() << ' '
      << q.z() << ' ' << q.w() << '\n';
  if (!out) throw Error(ErrorCode::kIo, path + ": cannot append");
}

}  // namespace

KeyframeFolder ReadKeyframeFolderIndex(const std::string& dir) {
  if (!fs::is_directory(dir)) throw Error(ErrorCode::kIo, dir + ": not a keyframe folder");
  KeyframeFolder folder;
  ReadCameraYaml(dir + "/camera.yaml", &folder.camera, &folder.depth_scale);
  const Trajectory poses = ReadTumTrajectory(dir + "/poses.txt");
  const auto covariances = ReadCovariances(dir + "/covariances.txt");
  for (const auto& pose : poses) {
    Keyframe keyframe;
    keyframe.t_ns = pose.t_ns;
    keyframe.T_map_cam = pose.T;
    if (auto it = covariances.find(pose.t_ns); it != covariances.end()) {
      keyframe.covariance = it->second;
    }
    folder.keyframes.push_back(std::move(keyframe));
  }
  return folder;
}

DepthImage ReadKeyframeDepth(const std::string& dir, const KeyframeFolder& folder, int64_t t_ns) {
  const std::string depth_path = dir + "/depth/" + std::to_string(t_ns) + ".png";
  DepthImage depth = ReadDepthPng(depth_path, folder.depth_scale);
  if (depth.width != folder.camera.width || depth.height != folder.camera.height) {
    throw Error(ErrorCode::kParse, depth_path + ": image is " + std::to_string(depth.width) + "x" +
                                       std::to_string(depth.height) + ", camera.yaml says " +
                                       std::to_string(folder.camera.width) + "x" +
                                       std::to_string(folder.camera.height));
  }
  return depth;
}

KeyframeFolder ReadKeyframeFolder(const std::string& dir) {
  KeyframeFolder folder = ReadKeyframeFolderIndex(dir);
  for (auto& keyframe : folder.keyframes)
    keyframe.depth = ReadKeyframeDepth(dir, folder, keyframe.t_ns);
  return folder;
}

void AppendKeyframe(const std::string& dir, const PinholeCamera& camera, double depth_scale,
                    const Keyframe& keyframe) {
  fs::create_directories(dir + "/depth");
  if (!fs::exists(dir + "/camera.yaml")) WriteCameraYaml(dir + "/camera.yaml", camera, depth_scale);
  WriteDepthPng(dir + "/depth/" + std::to_string(keyframe.t_ns) + ".png", keyframe.depth,
                depth_scale);
  if (keyframe.covariance) {
    AppendCovariance(dir + "/covariances.txt", keyframe.t_ns, *keyframe.covariance);
  }
  // The pose line goes last: a keyframe is listed only once its depth is on disk.
  AppendPose(dir + "/poses.txt", keyframe);
}

void WriteKeyframeFolder(const std::string& dir, const KeyframeFolder& folder) {
  fs::create_directories(dir);
  for (const char* name : {"/poses.txt", "/covariances.txt", "/camera.yaml"}) {
    fs::remove(dir + name);
  }
  WriteCameraYaml(dir + "/camera.yaml", folder.camera, folder.depth_scale);
  for (const auto& keyframe : folder.keyframes) {
    AppendKeyframe(dir, folder.camera, folder.depth_scale, keyframe);
  }
}

}  // namespace mapdelta
