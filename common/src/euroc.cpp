#include "mapdelta/common/euroc.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/trajectory_io.hpp"

namespace mapdelta {
namespace fs = std::filesystem;
namespace {

// EuRoC files start with OpenCV's "%YAML:1.0" directive, which yaml-cpp rejects (it expects
// "%YAML 1.x"): drop every directive line before parsing.
YAML::Node LoadYaml(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(ErrorCode::kIo, path + ": cannot open sensor.yaml");
  std::ostringstream text;
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] == '%') continue;
    text << line << '\n';
  }
  try {
    YAML::Node root = YAML::Load(text.str());
    if (!root.IsMap()) throw Error(ErrorCode::kParse, path + ": expected a YAML mapping");
    return root;
  } catch (const YAML::Exception& e) {
    throw Error(ErrorCode::kParse, path + ": invalid YAML: " + e.what());
  }
}

[[noreturn]] void FieldError(const std::string& path, const std::string& field,
                             const std::string& expected) {
  throw Error(ErrorCode::kParse, path + ": field '" + field + "': expected " + expected);
}

double ReadDouble(const YAML::Node& root, const std::string& path, const std::string& field) {
  const YAML::Node node = root[field];
  if (!node || !node.IsScalar()) FieldError(path, field, "a number");
  try {
    const double value = node.as<double>();
    if (!std::isfinite(value)) FieldError(path, field, "a finite number");
    return value;
  } catch (const YAML::Exception&) {
    FieldError(path, field, "a number");
  }
}

std::vector<double> ReadDoubles(const YAML::Node& node, const std::string& path,
                                const std::string& field) {
  if (!node || !node.IsSequence()) FieldError(path, field, "a list of numbers");
  std::vector<double> values;
  try {
    for (const auto& item : node) values.push_back(item.as<double>());
  } catch (const YAML::Exception&) {
    FieldError(path, field, "a list of numbers");
  }
  for (double v : values) {
    if (!std::isfinite(v)) FieldError(path, field, "finite numbers");
  }
  return values;
}

// T_BS: {rows: 4, cols: 4, data: [16 numbers, row-major]}.
SE3 ReadTBS(const YAML::Node& root, const std::string& path) {
  const YAML::Node node = root["T_BS"];
  if (!node || !node.IsMap()) FieldError(path, "T_BS", "a mapping with rows, cols, data");
  if (node["rows"] && node["cols"] &&
      (node["rows"].as<int>(0) != 4 || node["cols"].as<int>(0) != 4)) {
    FieldError(path, "T_BS", "rows: 4 and cols: 4");
  }
  const std::vector<double> data = ReadDoubles(node["data"], path, "T_BS.data");
  if (data.size() != 16) FieldError(path, "T_BS.data", "16 numbers (4x4 row-major)");
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) M(r, c) = data[4 * r + c];
  }
  const Eigen::Matrix3d R = M.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 ||
      std::abs(R.determinant() - 1.0) > 1e-3 ||
      (M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9) {
    FieldError(path, "T_BS.data", "a rigid transform (orthonormal rotation, last row 0 0 0 1)");
  }
  // Re-orthonormalize: EuRoC's published matrices are accurate to ~1e-6 only.
  SE3 T = SE3::Identity();
  T.linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

int64_t ParseTimestamp(const std::string& field, const std::string& path, int line_number) {
  try {
    size_t used = 0;
    const int64_t t = std::stoll(field, &used);
    if (field.find_first_not_of(" \t\r", used) == std::string::npos) return t;
  } catch (const std::exception&) {
  }
  throw Error(ErrorCode::kParse, path + ":" + std::to_string(line_number) +
                                     ": first field must be an integer timestamp in ns");
}

std::string Trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return "";
  const size_t b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

bool IsCommentOrBlank(const std::string& line) {
  const std::string t = Trim(line);
  return t.empty() || t[0] == '#';
}

void CheckIncreasing(const std::string& path, int64_t previous, int64_t current, int line) {
  if (current <= previous) {
    throw Error(ErrorCode::kParse,
                path + ":" + std::to_string(line) + ": timestamps must be strictly increasing");
  }
}

// depth0 may come with or without a data.csv; without one, list data/<t_ns>.png.
std::vector<EurocImage> ReadDepthList(const fs::path& depth_dir) {
  if (fs::exists(depth_dir / "data.csv")) {
    return ReadEurocImageList((depth_dir / "data.csv").string(), (depth_dir / "data").string());
  }
  std::vector<EurocImage> images;
  if (!fs::is_directory(depth_dir / "data")) return images;
  for (const auto& entry : fs::directory_iterator(depth_dir / "data")) {
    if (entry.path().extension() != ".png") continue;
    const std::string stem = entry.path().stem().string();
    if (stem.empty() || stem.find_first_not_of("0123456789") != std::string::npos) continue;
    images.push_back({std::stoll(stem), entry.path().string()});
  }
  std::sort(images.begin(), images.end(),
            [](const EurocImage& a, const EurocImage& b) { return a.t_ns < b.t_ns; });
  return images;
}

}  // namespace

bool EurocCamera::HasDistortion() const {
  return std::any_of(distortion.begin(), distortion.end(), [](double d) { return d != 0.0; });
}

EurocCamera ReadEurocCameraYaml(const std::string& path) {
  const YAML::Node root = LoadYaml(path);
  EurocCamera cam;
  cam.T_body_cam = ReadTBS(root, path);
  cam.rate_hz = ReadDouble(root, path, "rate_hz");
  if (cam.rate_hz <= 0) FieldError(path, "rate_hz", "a positive rate");
  const std::vector<double> resolution = ReadDoubles(root["resolution"], path, "resolution");
  if (resolution.size() != 2) FieldError(path, "resolution", "[width, height]");
  const std::vector<double> k = ReadDoubles(root["intrinsics"], path, "intrinsics");
  if (k.size() != 4) FieldError(path, "intrinsics", "[fx, fy, cx, cy]");
  if (root["camera_model"] && root["camera_model"].as<std::string>("") != "pinhole") {
    FieldError(path, "camera_model", "'pinhole'");
  }
  cam.intrinsics.width = static_cast<int>(resolution[0]);
  cam.intrinsics.height = static_cast<int>(resolution[1]);
  cam.intrinsics.fx = k[0];
  cam.intrinsics.fy = k[1];
  cam.intrinsics.cx = k[2];
  cam.intrinsics.cy = k[3];
  try {
    cam.intrinsics.Validate();
  } catch (const Error& e) {
    throw Error(ErrorCode::kParse, path + ": " + e.what());
  }
  if (root["distortion_model"]) cam.distortion_model = root["distortion_model"].as<std::string>("");
  if (root["distortion_coefficients"]) {
    cam.distortion = ReadDoubles(root["distortion_coefficients"], path, "distortion_coefficients");
  }
  return cam;
}

EurocImu ReadEurocImuYaml(const std::string& path) {
  const YAML::Node root = LoadYaml(path);
  EurocImu imu;
  imu.T_body_imu = ReadTBS(root, path);
  imu.rate_hz = ReadDouble(root, path, "rate_hz");
  if (imu.rate_hz <= 0) FieldError(path, "rate_hz", "a positive rate");
  auto density = [&](const char* field) {
    const double v = ReadDouble(root, path, field);
    if (v < 0) FieldError(path, field, "a non-negative density");
    return v;
  };
  imu.noise.gyroscope_noise_density = density("gyroscope_noise_density");
  imu.noise.gyroscope_random_walk = density("gyroscope_random_walk");
  imu.noise.accelerometer_noise_density = density("accelerometer_noise_density");
  imu.noise.accelerometer_random_walk = density("accelerometer_random_walk");
  return imu;
}

std::vector<EurocImage> ReadEurocImageList(const std::string& csv_path,
                                           const std::string& data_dir) {
  std::ifstream in(csv_path);
  if (!in) throw Error(ErrorCode::kIo, csv_path + ": cannot open image list");
  std::vector<EurocImage> images;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (IsCommentOrBlank(line)) continue;
    const size_t comma = line.find(',');
    if (comma == std::string::npos) {
      throw Error(ErrorCode::kParse,
                  csv_path + ":" + std::to_string(n) + ": expected 'timestamp [ns],filename'");
    }
    const int64_t t_ns = ParseTimestamp(line.substr(0, comma), csv_path, n);
    const std::string name = Trim(line.substr(comma + 1));
    if (name.empty()) {
      throw Error(ErrorCode::kParse, csv_path + ":" + std::to_string(n) + ": empty filename");
    }
    if (!images.empty()) CheckIncreasing(csv_path, images.back().t_ns, t_ns, n);
    images.push_back({t_ns, (fs::path(data_dir) / name).string()});
  }
  return images;
}

std::vector<ImuSample> ReadEurocImuCsv(const std::string& csv_path) {
  std::ifstream in(csv_path);
  if (!in) throw Error(ErrorCode::kIo, csv_path + ": cannot open IMU data");
  std::vector<ImuSample> samples;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (IsCommentOrBlank(line)) continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    std::string t_field;
    fields >> t_field;
    ImuSample s;
    s.t_ns = ParseTimestamp(t_field, csv_path, n);
    double v[6];
    for (double& x : v) {
      if (!(fields >> x) || !std::isfinite(x)) {
        throw Error(ErrorCode::kParse, csv_path + ":" + std::to_string(n) +
                                           ": expected 'timestamp, wx, wy, wz, ax, ay, az'");
      }
    }
    s.gyro = {v[0], v[1], v[2]};
    s.accel = {v[3], v[4], v[5]};
    if (!samples.empty()) CheckIncreasing(csv_path, samples.back().t_ns, s.t_ns, n);
    samples.push_back(s);
  }
  return samples;
}

EurocSequence ReadEurocSequence(const std::string& dir) {
  fs::path mav0 = fs::path(dir);
  if (!fs::is_directory(mav0 / "cam0") && fs::is_directory(mav0 / "mav0")) mav0 /= "mav0";
  if (!fs::is_directory(mav0 / "cam0")) {
    throw Error(ErrorCode::kNotFound, dir + ": not an EuRoC sequence (no mav0/cam0 folder)");
  }
  EurocSequence seq;
  seq.mav0_dir = mav0.string();
  const auto camera = [&](const char* name, EurocCamera* cam, std::vector<EurocImage>* images) {
    const fs::path d = mav0 / name;
    *cam = ReadEurocCameraYaml((d / "sensor.yaml").string());
    *images = ReadEurocImageList((d / "data.csv").string(), (d / "data").string());
  };
  camera("cam0", &seq.cam0, &seq.cam0_images);
  camera("cam1", &seq.cam1, &seq.cam1_images);
  seq.imu = ReadEurocImuYaml((mav0 / "imu0" / "sensor.yaml").string());
  seq.imu_samples = ReadEurocImuCsv((mav0 / "imu0" / "data.csv").string());
  const fs::path gt = mav0 / "state_groundtruth_estimate0" / "data.csv";
  if (fs::exists(gt)) seq.groundtruth = ReadEurocTrajectory(gt.string());
  seq.depth0_images = ReadDepthList(mav0 / "depth0");
  return seq;
}

std::vector<StereoFrameFiles> EurocSequence::StereoFrames() const {
  std::vector<StereoFrameFiles> frames;
  size_t j = 0;
  for (const auto& left : cam0_images) {
    while (j < cam1_images.size() && cam1_images[j].t_ns < left.t_ns) ++j;
    if (j < cam1_images.size() && cam1_images[j].t_ns == left.t_ns) {
      frames.push_back({left.t_ns, left.path, cam1_images[j].path});
    }
  }
  return frames;
}

SE3 EurocSequence::T_cam0_cam1() const { return cam0.T_body_cam.inverse() * cam1.T_body_cam; }

StereoRig MakeRectifiedStereoRig(const EurocSequence& sequence) {
  const SE3 T = sequence.T_cam0_cam1();
  const Eigen::Vector3d t = T.translation();
  const double baseline = t.norm();
  const std::string where = sequence.mav0_dir + ": cam0/cam1 sensor.yaml";
  if (sequence.cam0.HasDistortion() || sequence.cam1.HasDistortion()) {
    throw Error(ErrorCode::kUnsupported, where + ": images are not rectified (distortion)");
  }
  if (RotationAngle(T, SE3::Identity()) > 1e-3 || baseline <= 0 ||
      std::hypot(t.y(), t.z()) > 1e-3 * baseline || t.x() <= 0) {
    throw Error(ErrorCode::kUnsupported,
                where + ": pair is not rectified (cam1 must sit at +x of cam0, same rotation)");
  }
  StereoRig rig;
  rig.left = sequence.cam0.intrinsics;
  rig.baseline_m = baseline;
  rig.T_body_cam0 = sequence.cam0.T_body_cam;
  return rig;
}

}  // namespace mapdelta
