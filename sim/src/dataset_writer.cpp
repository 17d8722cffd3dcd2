#include "mapdelta/sim/dataset_writer.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <fstream>

#include "mapdelta/common/error.hpp"

namespace mapdelta::sim {
namespace {

std::ofstream Open(const std::string& path) {
  std::ofstream out(path);
  if (!out) throw Error(ErrorCode::kIo, path + ": cannot open for writing");
  return out;
}

void Close(std::ofstream& out, const std::string& path) {
  out.close();
  if (!out) throw Error(ErrorCode::kIo, path + ": write failed");
}

std::string Num(double v) { return FormatCsvNumber(v); }

std::string MatrixYaml(const SE3& T) {
  std::string s = "T_BS:\n  cols: 4\n  rows: 4\n  data: [";
  const Eigen::Matrix4d M = T.matrix();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) s += Num(M(r, c)) + (r == 3 && c == 3 ? "]\n" : ", ");
  }
  return s;
}

nlohmann::json BoxJson(const Box& b) {
  return {{"min", {b.min.x(), b.min.y(), b.min.z()}}, {"max", {b.max.x(), b.max.y(), b.max.z()}}};
}

const char* MaterialName(Material m) {
  switch (m) {
    case Material::kBrick:
      return "brick";
    case Material::kPlaster:
      return "plaster";
    case Material::kConcrete:
      return "concrete";
    case Material::kCar:
      return "car";
    case Material::kTrunk:
      return "trunk";
    case Material::kFoliage:
      return "foliage";
    case Material::kMetal:
      return "metal";
    case Material::kMirror:
      return "mirror";
  }
  return "?";
}

nlohmann::json ObjectJson(const Object& o) {
  nlohmann::json boxes = nlohmann::json::array();
  for (const Box& b : o.boxes) boxes.push_back(BoxJson(b));
  return {{"id", o.id},
          {"kind", o.kind},
          {"material", MaterialName(o.material)},
          {"bounds", BoxJson(o.Bounds())},
          {"boxes", boxes}};
}

}  // namespace

std::string FormatCsvNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.10g", v);
  return buf;
}

SE3 BodyToCam0() {
  SE3 T = SE3::Identity();
  // Columns: camera x (right) = body -y, camera y (down) = body -z, camera z (forward) = body x.
  T.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  T.translation() = Eigen::Vector3d(0.10, 0.50, 0.05);  // left camera half a baseline to the left
  return T;
}

void WriteCameraYaml(const std::string& path, const PinholeCamera& cam, double rate_hz,
                     const SE3& T_body_cam, const std::string& comment,
                     const std::array<double, 4>& radtan) {
  std::string coeffs = "[0.0, 0.0, 0.0, 0.0]";
  if (radtan != std::array<double, 4>{0, 0, 0, 0}) {
    coeffs = "[" + Num(radtan[0]) + ", " + Num(radtan[1]) + ", " + Num(radtan[2]) + ", " +
             Num(radtan[3]) + "]";
  }
  std::ofstream out = Open(path);
  out << "# General sensor definitions.\nsensor_type: camera\ncomment: " << comment << "\n\n"
      << "# Sensor extrinsics wrt. the body-frame.\n"
      << MatrixYaml(T_body_cam) << "\n# Camera specific definitions.\nrate_hz: " << Num(rate_hz)
      << "\nresolution: [" << cam.width << ", " << cam.height
      << "]\ncamera_model: pinhole\nintrinsics: [" << Num(cam.fx) << ", " << Num(cam.fy) << ", "
      << Num(cam.cx) << ", " << Num(cam.cy)
      << "] #fu, fv, cu, cv\ndistortion_model: radial-tangential\ndistortion_coefficients: "
      << coeffs << "\n";
  Close(out, path);
}

void WriteImuYaml(const std::string& path, double rate_hz, const NoiseParams& n) {
  std::ofstream out = Open(path);
  out << "# General sensor definitions.\nsensor_type: imu\ncomment: mapdelta-sim IMU (body frame x "
         "forward, y left, z up)\n\n"
      << "# Sensor extrinsics wrt. the body-frame.\n"
      << MatrixYaml(SE3::Identity()) << "rate_hz: " << Num(rate_hz) << "\n\n"
      << "# inertial sensor noise model parameters (static), continuous-time densities\n"
      << "gyroscope_noise_density: " << Num(n.gyro_noise_density)
      << "     # [ rad / s / sqrt(Hz) ]\n"
      << "gyroscope_random_walk: " << Num(n.gyro_random_walk)
      << "       # [ rad / s^2 / sqrt(Hz) ]\n"
      << "accelerometer_noise_density: " << Num(n.accel_noise_density)
      << " # [ m / s^2 / sqrt(Hz) ]\n"
      << "accelerometer_random_walk: " << Num(n.accel_random_walk)
      << "   # [ m / s^3 / sqrt(Hz) ]\n";
  Close(out, path);
}

void WriteImageCsv(const std::string& path, const std::vector<int64_t>& t_ns) {
  std::ofstream out = Open(path);
  out << "#timestamp [ns],filename\n";
  for (int64_t t : t_ns) out << t << ',' << t << ".png\n";
  Close(out, path);
}

void WriteImuCsv(const std::string& path, const std::vector<ImuSample>& imu) {
  std::ofstream out = Open(path);
  out << "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
         "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n";
  for (const ImuSample& s : imu) {
    out << s.t_ns;
    for (int k = 0; k < 3; ++k) out << ',' << Num(s.gyro[k]);
    for (int k = 0; k < 3; ++k) out << ',' << Num(s.accel[k]);
    out << '\n';
  }
  Close(out, path);
}

void WriteGroundTruthCsv(const std::string& path, const SplineTrajectory& traj,
                         const std::vector<ImuSample>& imu, int64_t t0_ns,
                         const SE3& T_vehicle_body) {
  std::ofstream out = Open(path);
  out << "#timestamp,p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],q_RS_z "
         "[],"
         "v_RS_R_x [m s^-1],v_RS_R_y [m s^-1],v_RS_R_z [m s^-1],b_w_RS_S_x [rad s^-1],b_w_RS_S_y "
         "[rad s^-1],"
         "b_w_RS_S_z [rad s^-1],b_a_RS_S_x [m s^-2],b_a_RS_S_y [m s^-2],b_a_RS_S_z [m s^-2]\n";
  Eigen::Quaterniond prev = Eigen::Quaterniond::Identity();
  for (const ImuSample& s : imu) {
    const MotionState m = traj.Evaluate(static_cast<double>(s.t_ns - t0_ns) * 1e-9);
    Eigen::Quaterniond q(Eigen::Matrix3d(m.T_map_body.linear() * T_vehicle_body.linear()));
    if (q.coeffs().dot(prev.coeffs()) < 0) q.coeffs() *= -1.0;  // no sign flips between rows
    prev = q;
    out << s.t_ns;
    for (int k = 0; k < 3; ++k) out << ',' << Num(m.p_map[k]);
    out << ',' << Num(q.w()) << ',' << Num(q.x()) << ',' << Num(q.y()) << ',' << Num(q.z());
    for (int k = 0; k < 3; ++k) out << ',' << Num(m.v_map[k]);
    for (int k = 0; k < 3; ++k) out << ',' << Num(s.bias_gyro[k]);
    for (int k = 0; k < 3; ++k) out << ',' << Num(s.bias_accel[k]);
    out << '\n';
  }
  Close(out, path);
}

void WriteObjectsJson(const std::string& path, const Scene& scene,
                      const std::vector<Change>& changes) {
  nlohmann::json objects = nlohmann::json::array();
  for (const Object& o : scene.objects) objects.push_back(ObjectJson(o));
  nlohmann::json ch = nlohmann::json::array();
  for (const Change& c : changes) {
    nlohmann::json j = ObjectJson(c.object);
    j["type"] = c.type;
    ch.push_back(j);
  }
  const nlohmann::json doc = {
      {"scene", scene.name},
      {"frame", "map (z up, metres)"},
      {"extent", {scene.extent_x, scene.extent_y}},
      {"streets",
       {{"xs", scene.streets.xs}, {"ys", scene.streets.ys}, {"width", scene.streets.width}}},
      {"objects", objects},
      {"changes", ch}};
  std::ofstream out = Open(path);
  out << doc.dump(1) << '\n';
  Close(out, path);
}

void WriteGreyPng(const std::string& path, int width, int height,
                  const std::vector<uint8_t>& pixels) {
  const cv::Mat img(height, width, CV_8UC1, const_cast<uint8_t*>(pixels.data()));
  bool ok = false;
  try {
    ok = cv::imwrite(path, img);
  } catch (const cv::Exception&) {
    ok = false;
  }
  if (!ok) throw Error(ErrorCode::kIo, path + ": could not write PNG");
}

}  // namespace mapdelta::sim
