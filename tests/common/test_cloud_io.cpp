// Cloud readers against PCL's writers (the oracle for the formats), and robustness: truncated,
// bit-flipped and random files must give mapdelta::Error, never a crash.
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>
#include <pcl/register_point_struct.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/error.hpp"
#include "support/temp_dir.hpp"

// How a third-party tool would read mapdelta's change clouds: its own point type, by field name.
struct ReaderChangePoint {
  PCL_ADD_POINT4D;
  float confidence;
  uint32_t observed_by;
  uint32_t supported_by;
  PCL_MAKE_ALIGNED_OPERATOR_NEW
};
// clang-format off
POINT_CLOUD_REGISTER_POINT_STRUCT(ReaderChangePoint,
    (float, x, x)(float, y, y)(float, z, z)(float, confidence, confidence)
    (uint32_t, observed_by, observed_by)(uint32_t, supported_by, supported_by))
// clang-format on

namespace mapdelta {
namespace {

std::string TempDir(const std::string& name) {
  return mapdelta::testing::FreshTempDir("mapdelta_test_" + name).string();
}

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

pcl::PointCloud<pcl::PointXYZI> RandomPclCloud(size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> coord(-100, 100);
  pcl::PointCloud<pcl::PointXYZI> cloud;
  for (size_t i = 0; i < n; ++i) {
    pcl::PointXYZI p;
    p.x = coord(rng);
    p.y = coord(rng);
    p.z = coord(rng);
    p.intensity = coord(rng);
    cloud.push_back(p);
  }
  return cloud;
}

void ExpectSame(const pcl::PointCloud<pcl::PointXYZI>& expected, const PointCloud& got, float tol) {
  ASSERT_EQ(got.size(), expected.size());
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_NEAR(got[i].x(), expected[i].x, tol);
    EXPECT_NEAR(got[i].y(), expected[i].y, tol);
    EXPECT_NEAR(got[i].z(), expected[i].z, tol);
  }
}

TEST(CloudIo, ReadsEveryPclEncodingWithExtraFields) {
  const std::string dir = TempDir("cloud_io_pcl");
  const auto cloud = RandomPclCloud(500, 11);
  ASSERT_EQ(pcl::io::savePCDFileASCII(dir + "/a.pcd", cloud), 0);
  ExpectSame(cloud, ReadCloud(dir + "/a.pcd"), 1e-3f);
  ASSERT_EQ(pcl::io::savePCDFileBinary(dir + "/b.pcd", cloud), 0);
  ExpectSame(cloud, ReadCloud(dir + "/b.pcd"), 0.f);
  ASSERT_EQ(pcl::io::savePCDFileBinaryCompressed(dir + "/c.pcd", cloud), 0);
  ExpectSame(cloud, ReadCloud(dir + "/c.pcd"), 0.f);
  ASSERT_EQ(pcl::io::savePLYFileASCII(dir + "/d.ply", cloud), 0);
  ExpectSame(cloud, ReadCloud(dir + "/d.ply"), 1e-3f);
  ASSERT_EQ(pcl::io::savePLYFileBinary(dir + "/e.ply", cloud), 0);
  ExpectSame(cloud, ReadCloud(dir + "/e.ply"), 0.f);
}

TEST(CloudIo, ChangeCloudEvidenceFieldsReadBackByPcl) {
  const std::string dir = TempDir("cloud_io_changes");
  std::vector<ChangeCloudPoint> points;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> coord(-50, 50);
  for (uint32_t i = 0; i < 300; ++i) {
    const uint32_t observed = 1 + i % 7, supported = i % (observed + 1);
    points.push_back({Point(coord(rng), coord(rng), coord(rng)),
                      (supported + 1.0f) / (observed + 2.0f), observed, supported});
  }
  for (const std::string ext : {".pcd", ".ply"}) {
    const std::string path = dir + "/changes" + ext;
    WriteChangeCloud(path, points);
    // PCL's generic reader sees the fields by name and type ...
    pcl::PCLPointCloud2 blob;
    ASSERT_EQ(ext == ".pcd" ? pcl::io::loadPCDFile(path, blob) : pcl::io::loadPLYFile(path, blob),
              0);
    std::vector<std::pair<std::string, int>> fields;
    for (const auto& f : blob.fields) fields.emplace_back(f.name, f.datatype);
    const std::vector<std::pair<std::string, int>> expected = {
        {"x", pcl::PCLPointField::FLOAT32},          {"y", pcl::PCLPointField::FLOAT32},
        {"z", pcl::PCLPointField::FLOAT32},          {"confidence", pcl::PCLPointField::FLOAT32},
        {"observed_by", pcl::PCLPointField::UINT32}, {"supported_by", pcl::PCLPointField::UINT32}};
    EXPECT_EQ(fields, expected) << path;
    // ... and a reader's own point type gets every value back exactly.
    pcl::PointCloud<ReaderChangePoint> read;
    pcl::fromPCLPointCloud2(blob, read);
    ASSERT_EQ(read.size(), points.size()) << path;
    for (size_t i = 0; i < points.size(); ++i) {
      EXPECT_EQ(Point(read[i].x, read[i].y, read[i].z), points[i].position);
      EXPECT_EQ(read[i].confidence, points[i].confidence);
      EXPECT_EQ(read[i].observed_by, points[i].observed_by);
      EXPECT_EQ(read[i].supported_by, points[i].supported_by);
    }
    // Our own reader (the prior import) takes x y z and skips the rest.
    const PointCloud xyz = ReadCloud(path);
    ASSERT_EQ(xyz.size(), points.size());
    EXPECT_EQ(xyz.back(), points.back().position);
  }
  // No changes is a valid answer: an empty PCD with the same fields, readable by both.
  WriteChangeCloud(dir + "/none.pcd", {});
  pcl::PCLPointCloud2 empty;
  ASSERT_EQ(pcl::io::loadPCDFile(dir + "/none.pcd", empty), 0);
  EXPECT_EQ(empty.fields.size(), 6u);
  EXPECT_EQ(empty.width * empty.height, 0u);
  EXPECT_TRUE(ReadCloud(dir + "/none.pcd").empty());
}

TEST(CloudIo, PlyWithFacesBeforeVerticesAndBigEndianDoubles) {
  const std::string dir = TempDir("cloud_io_ply");
  std::string bytes =
      "ply\nformat binary_big_endian 1.0\ncomment faces first\nelement face 1\n"
      "property list uchar int vertex_indices\nelement vertex 2\nproperty double x\n"
      "property double y\nproperty double z\nend_header\n";
  const auto put_be = [&](const void* value, int size) {
    const auto* b = static_cast<const char*>(value);
    for (int i = size - 1; i >= 0; --i) bytes.push_back(b[i]);
  };
  const unsigned char three = 3;
  put_be(&three, 1);
  for (int32_t index : {0, 1, 0}) put_be(&index, 4);
  for (double v : {1.5, -2.0, 3.25, 4.0, 5.0, -6.5}) put_be(&v, 8);
  WriteBytes(dir + "/f.ply", bytes);
  const PointCloud cloud = ReadCloud(dir + "/f.ply");
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_EQ(cloud[0], Point(1.5f, -2.0f, 3.25f));
  EXPECT_EQ(cloud[1], Point(4.0f, 5.0f, -6.5f));
}

TEST(CloudIo, HeaderErrorsNameFileAndField) {
  const std::string dir = TempDir("cloud_io_header");
  const auto message = [&](const std::string& name, const std::string& text) {
    WriteBytes(dir + "/" + name, text);
    try {
      ReadCloud(dir + "/" + name);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string good_tail = "WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n";
  EXPECT_NE(
      message("nox.pcd", "FIELDS a y z\nSIZE 4 4 4\nTYPE F F F\n" + good_tail).find("x, y and z"),
      std::string::npos);
  EXPECT_NE(message("size.pcd", "FIELDS x y z\nSIZE 4 4\nTYPE F F F\n" + good_tail).find("SIZE"),
            std::string::npos);
  EXPECT_NE(message("pts.pcd",
                    "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 1\nPOINTS 2\n"
                    "DATA binary\n123456789012")
                .find("truncated"),
            std::string::npos);
  EXPECT_NE(
      message("data.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nDATA zip\n")
          .find("DATA"),
      std::string::npos);
  const std::string m = message("v.ply",
                                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                "property float y\nproperty float z\nend_header\n1 2 3\n");
  EXPECT_NE(m.find("v.ply"), std::string::npos) << m;
  EXPECT_NE(message("m.ply", "plx\n").find("'ply'"), std::string::npos);
}

// Every file must either parse or throw mapdelta::Error; anything else fails (or crashes) here.
void ExpectErrorOrCloud(const std::string& path) {
  try {
    ReadCloud(path);
  } catch (const Error&) {
  }
}

TEST(CloudIo, TruncatedAndCorruptedFilesNeverCrash) {
  const std::string dir = TempDir("cloud_io_fuzz");
  const auto cloud = RandomPclCloud(200, 5);
  pcl::io::savePCDFileASCII(dir + "/a.pcd", cloud);
  pcl::io::savePCDFileBinary(dir + "/b.pcd", cloud);
  pcl::io::savePCDFileBinaryCompressed(dir + "/c.pcd", cloud);
  pcl::io::savePLYFileASCII(dir + "/d.ply", cloud);
  pcl::io::savePLYFileBinary(dir + "/e.ply", cloud);
  std::mt19937 rng(1234);
  for (const char* name : {"a.pcd", "b.pcd", "c.pcd", "d.ply", "e.ply"}) {
    const std::string original = ReadBytes(dir + "/" + name);
    const std::string ext = std::string(name).substr(1);
    const std::string path = dir + "/fuzz" + ext;
    // Truncations: a binary file cut anywhere before its end is an error, never a smaller cloud.
    for (int k = 0; k < 60; ++k) {
      const size_t cut = std::uniform_int_distribution<size_t>(0, original.size() - 2)(rng);
      WriteBytes(path, original.substr(0, cut));
      if (std::string(name) == "b.pcd" || std::string(name) == "c.pcd") {
        EXPECT_THROW(ReadCloud(path), Error) << name << " cut at " << cut;
      } else {
        ExpectErrorOrCloud(path);
      }
    }
    // Random byte flips anywhere, header included.
    for (int k = 0; k < 60; ++k) {
      std::string corrupted = original;
      for (int flips = 0; flips < 4; ++flips) {
        corrupted[std::uniform_int_distribution<size_t>(0, corrupted.size() - 1)(rng)] =
            static_cast<char>(rng());
      }
      WriteBytes(path, corrupted);
      ExpectErrorOrCloud(path);
    }
  }
  // Pure random bytes, and random bytes behind a valid header.
  const std::string header =
      "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1000\nHEIGHT 1\nDATA binary_compressed\n";
  for (int k = 0; k < 40; ++k) {
    std::string noise(std::uniform_int_distribution<size_t>(0, 4000)(rng), '\0');
    for (auto& c : noise) c = static_cast<char>(rng());
    WriteBytes(dir + "/r.pcd", noise);
    EXPECT_THROW(ReadCloud(dir + "/r.pcd"), Error);
    WriteBytes(dir + "/r.ply", noise);
    EXPECT_THROW(ReadCloud(dir + "/r.ply"), Error);
    WriteBytes(dir + "/h.pcd", header + noise);
    EXPECT_THROW(ReadCloud(dir + "/h.pcd"), Error);
  }
}

}  // namespace
}  // namespace mapdelta
