// EuRoC reader: a folder written here with the real EuRoC MH_01 cam0/cam1/imu0 sensor.yaml
// text (including its "%YAML:1.0" directive) must load with the published numbers.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/euroc.hpp"
#include "support/temp_dir.hpp"

namespace fs = std::filesystem;
using namespace mapdelta;

namespace {

const char* kCam0Yaml = R"(%YAML:1.0
# General sensor definitions.
sensor_type: camera
comment: VI-Sensor cam0 (MT9M034)

# Sensor extrinsics wrt. the body-frame.
T_BS:
  cols: 4
  rows: 4
  data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,
         0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,
        -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,
         0.0, 0.0, 0.0, 1.0]

# Camera specific definitions.
rate_hz: 20
resolution: [752, 480]
camera_model: pinhole
intrinsics: [458.654, 457.296, 367.215, 248.375] #fu, fv, cu, cv
distortion_model: radial-tangential
distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
)";

const char* kImuYaml = R"(%YAML:1.0
sensor_type: imu
comment: VI-Sensor IMU (ADIS16448)
T_BS:
  cols: 4
  rows: 4
  data: [1.0, 0.0, 0.0, 0.0,
         0.0, 1.0, 0.0, 0.0,
         0.0, 0.0, 1.0, 0.0,
         0.0, 0.0, 0.0, 1.0]
rate_hz: 200
gyroscope_noise_density: 1.6968e-04     # [ rad / s / sqrt(Hz) ]   ( gyro "white noise" )
gyroscope_random_walk: 1.9393e-05       # [ rad / s^2 / sqrt(Hz) ] ( gyro bias diffusion )
accelerometer_noise_density: 2.0000e-3  # [ m / s^2 / sqrt(Hz) ]   ( accel "white noise" )
accelerometer_random_walk: 3.0000e-3    # [ m / s^3 / sqrt(Hz) ].  ( accel bias diffusion )
)";

void Write(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << text;
}

fs::path MakeFolder(const std::string& name) {
  const fs::path root = mapdelta::testing::FreshTempDir("mapdelta_euroc_" + name);
  fs::remove_all(root);
  const fs::path mav0 = root / "mav0";
  Write(mav0 / "cam0/sensor.yaml", kCam0Yaml);
  Write(mav0 / "cam1/sensor.yaml", kCam0Yaml);
  Write(mav0 / "cam0/data.csv",
        "#timestamp [ns],filename\n100,100.png\n200,200.png\n300,300.png\n");
  Write(mav0 / "cam1/data.csv", "#timestamp [ns],filename\n100,100.png\n300,300.png\n");
  Write(mav0 / "imu0/sensor.yaml", kImuYaml);
  Write(mav0 / "imu0/data.csv",
        "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
        "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n"
        "1403636579758555392,-0.099134701513277898,0.14730578886832138,0.02722713633111154,"
        "8.1476917083333333,-0.37592158333333331,-2.4026292499999999\n"
        "1403636579763555584,-0.099134701513277898,0.14032447186034408,0.029321531433504733,"
        "8.033280791666666,-0.40861041666666664,-2.4026292499999999\n");
  return root;
}

}  // namespace

TEST(Euroc, LoadsRealEurocSensorYamlAndLists) {
  const fs::path root = MakeFolder("ok");
  const EurocSequence seq = ReadEurocSequence(root.string());
  EXPECT_DOUBLE_EQ(seq.cam0.rate_hz, 20.0);
  EXPECT_EQ(seq.cam0.intrinsics.width, 752);
  EXPECT_EQ(seq.cam0.intrinsics.height, 480);
  EXPECT_DOUBLE_EQ(seq.cam0.intrinsics.fx, 458.654);
  EXPECT_DOUBLE_EQ(seq.cam0.intrinsics.cy, 248.375);
  EXPECT_EQ(seq.cam0.distortion_model, "radial-tangential");
  ASSERT_EQ(seq.cam0.distortion.size(), 4u);
  EXPECT_TRUE(seq.cam0.HasDistortion());
  // Row-major: element (0,3) is the x translation, (1,0) the second row's first entry.
  EXPECT_NEAR(seq.cam0.T_body_cam.translation().x(), -0.0216401454975, 1e-12);
  EXPECT_NEAR(seq.cam0.T_body_cam.translation().y(), -0.064676986768, 1e-12);
  EXPECT_NEAR(seq.cam0.T_body_cam.linear()(1, 0), 0.999557249008, 1e-6);
  EXPECT_NEAR(seq.imu.noise.gyroscope_noise_density, 1.6968e-04, 1e-15);
  EXPECT_NEAR(seq.imu.noise.accelerometer_random_walk, 3.0e-3, 1e-15);
  ASSERT_EQ(seq.imu_samples.size(), 2u);
  EXPECT_EQ(seq.imu_samples[1].t_ns, 1403636579763555584LL);
  EXPECT_NEAR(seq.imu_samples[0].accel.x(), 8.1476917083333333, 1e-12);
  ASSERT_EQ(seq.cam0_images.size(), 3u);
  EXPECT_EQ(fs::path(seq.cam0_images[1].path), root / "mav0/cam0/data/200.png");
  const auto frames = seq.StereoFrames();  // 200 has no right image
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[1].t_ns, 300);
  EXPECT_TRUE(seq.groundtruth.empty());
  EXPECT_TRUE(seq.depth0_images.empty());
  EXPECT_THROW(MakeRectifiedStereoRig(seq), Error);  // distorted: not rectified
}

TEST(Euroc, ErrorsNameFileAndField) {
  const fs::path root = MakeFolder("bad");
  std::string yaml = kCam0Yaml;
  yaml.replace(yaml.find("intrinsics: [458.654, "), 22, "intrinsics: [");
  Write(root / "mav0/cam0/sensor.yaml", yaml);
  try {
    ReadEurocSequence(root.string());
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("cam0/sensor.yaml"), std::string::npos) << what;
    EXPECT_NE(what.find("intrinsics"), std::string::npos) << what;
  }
  Write(root / "mav0/cam0/sensor.yaml", kCam0Yaml);
  Write(root / "mav0/imu0/data.csv", "1,2,3\n");
  try {
    ReadEurocSequence(root.string());
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("imu0/data.csv:1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ReadEurocSequence((root / "nothing").string()), Error);
}
