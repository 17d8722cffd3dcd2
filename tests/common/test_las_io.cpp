// LAS 1.2 / 1.4 (common/las_io.hpp): round trips through files, a file laid out by hand from
// the ASPRS specification's field offsets (our oracle: no LAS library is in Debian 12), the
// writer's bytes at those offsets, and malformed files rejected with the field named.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "mapdelta/common/cloud_io.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/las_io.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta {
namespace {

template <typename T>
void Put(std::string* b, size_t at, T v) {
  std::memcpy(b->data() + at, &v, sizeof(T));
}
template <typename T>
T Get(const std::string& b, size_t at) {
  T v;
  std::memcpy(&v, b.data() + at, sizeof(T));
  return v;
}

// A LAS 1.2 file with point format 1 (28-byte records: X Y Z, intensity, flags, class, scan
// angle, user data, point source, GPS time), one 54-byte VLR between header and points, scale
// 0.01 and offset (500000, 5400000, 10): UTM-like coordinates as map teams have them.
std::string HandMadeLas12() {
  const size_t header = 227, vlr = 54, record = 28, points = 3;
  std::string b(header + vlr + points * record, '\0');
  std::memcpy(b.data(), "LASF", 4);
  Put<uint8_t>(&b, 24, 1);
  Put<uint8_t>(&b, 25, 2);
  Put<uint16_t>(&b, 94, header);
  Put<uint32_t>(&b, 96, header + vlr);  // offset to point data
  Put<uint32_t>(&b, 100, 1);            // number of VLRs
  Put<uint8_t>(&b, 104, 1);             // point data format
  Put<uint16_t>(&b, 105, record);
  Put<uint32_t>(&b, 107, points);
  const double scale[3] = {0.01, 0.01, 0.01}, offset[3] = {500000, 5400000, 10};
  for (int a = 0; a < 3; ++a) {
    Put<double>(&b, 131 + 8 * a, scale[a]);
    Put<double>(&b, 155 + 8 * a, offset[a]);
  }
  const int32_t xyz[3][3] = {{0, 0, 0}, {12345, -6789, 250}, {-100, 100, -1000}};
  for (size_t i = 0; i < points; ++i) {
    for (int a = 0; a < 3; ++a) Put<int32_t>(&b, header + vlr + i * record + 4 * a, xyz[i][a]);
    Put<uint16_t>(&b, header + vlr + i * record + 12, 999);  // intensity: not ours to read
  }
  return b;
}

TEST(LasIo, ReadsAFileLaidOutFromTheSpecification) {
  const PointCloud c = ParseLas(HandMadeLas12(), "hand.las");
  ASSERT_EQ(c.size(), 3u);
  // float32 keeps ~0.5 m at northing 5.4e6 (PointCloud's precision, not the reader's).
  EXPECT_NEAR(c[1].x(), 500000 + 123.45, 0.05);
  EXPECT_NEAR(c[1].y(), 5400000 - 67.89, 0.5);
  EXPECT_NEAR(c[1].z(), 10 + 2.5, 1e-5);
  EXPECT_NEAR(c[2].z(), 10 - 10.0, 1e-5);
}

TEST(LasIo, WritesTheSpecificationsLayout) {
  const PointCloud cloud = {{1.0f, 2.0f, 3.0f}, {-4.25f, 5.5f, 0.125f}};
  const std::string b = EncodeLas(cloud);
  ASSERT_EQ(b.size(), 227u + 2 * 20);
  EXPECT_EQ(b.substr(0, 4), "LASF");
  EXPECT_EQ(Get<uint8_t>(b, 24), 1);
  EXPECT_EQ(Get<uint8_t>(b, 25), 2);
  EXPECT_EQ(Get<uint16_t>(b, 94), 227);
  EXPECT_EQ(Get<uint32_t>(b, 96), 227u);
  EXPECT_EQ(Get<uint8_t>(b, 104), 0);
  EXPECT_EQ(Get<uint16_t>(b, 105), 20);
  EXPECT_EQ(Get<uint32_t>(b, 107), 2u);
  EXPECT_EQ(Get<uint32_t>(b, 111), 2u);  // points by return: all first returns
  EXPECT_DOUBLE_EQ(Get<double>(b, 131), 0.001);
  EXPECT_DOUBLE_EQ(Get<double>(b, 155), -5.0);   // x offset: min x floored
  EXPECT_DOUBLE_EQ(Get<double>(b, 179), 1.0);    // max x
  EXPECT_DOUBLE_EQ(Get<double>(b, 187), -4.25);  // min x
  EXPECT_DOUBLE_EQ(Get<double>(b, 219), 0.125);  // min z
  EXPECT_EQ(Get<int32_t>(b, 227 + 20), 750);     // (-4.25 - -5) / 0.001
  EXPECT_EQ(Get<uint8_t>(b, 227 + 14), 0x09);    // return 1 of 1
  const std::string b14 = EncodeLas(cloud, {4, 0.001});
  EXPECT_EQ(Get<uint8_t>(b14, 25), 4);
  EXPECT_EQ(Get<uint16_t>(b14, 94), 375);
  EXPECT_EQ(Get<uint8_t>(b14, 104), 6);
  EXPECT_EQ(Get<uint16_t>(b14, 105), 30);
  EXPECT_EQ(Get<uint32_t>(b14, 107), 0u);  // legacy count is zero for formats 6-10
  EXPECT_EQ(Get<uint64_t>(b14, 247), 2u);
}

TEST(LasIo, RoundTripsThroughFilesToTheScale) {
  const auto dir = testing::FreshTempDir("las_io");
  PointCloud cloud;  // within +-1 km: float32 resolves 0.06 mm there, below the 1 mm LAS scale
  for (int i = 0; i < 1000; ++i)
    cloud.push_back({0.37f * i - 100.0f, 0.001f * i * i, -3.0f + 0.0123f * i});
  WriteCloud((dir / "a.las").string(), cloud);
  const PointCloud back = ReadCloud((dir / "a.las").string());
  ASSERT_EQ(back.size(), cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i)
    EXPECT_LE((back[i] - cloud[i]).cwiseAbs().maxCoeff(), 0.0005 + 1e-4) << i;
  const std::string b14 = EncodeLas(cloud, {4, 0.0001});
  const PointCloud back14 = ParseLas(b14, "v14");
  ASSERT_EQ(back14.size(), cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i)
    EXPECT_LE((back14[i] - cloud[i]).cwiseAbs().maxCoeff(), 1e-4) << i;
  EXPECT_TRUE(ParseLas(EncodeLas({}), "empty").empty());
  std::filesystem::remove_all(dir);
}

std::string ParseError(const std::string& bytes) {
  try {
    ParseLas(bytes, "bad.las");
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(LasIo, MalformedFilesNameTheField) {
  std::string truncated = HandMadeLas12();
  truncated.resize(truncated.size() - 1);
  EXPECT_EQ(ParseError(truncated), "bad.las: header says 3 points of 28 bytes, the file holds 2");
  std::string laz = HandMadeLas12();
  Put<uint8_t>(&laz, 104, 0x81);  // LASzip sets the top bits of the format byte
  EXPECT_NE(ParseError(laz).find("LAZ (compressed LAS"), std::string::npos);
  std::string short_record = HandMadeLas12();
  Put<uint16_t>(&short_record, 105, 20);
  EXPECT_NE(ParseError(short_record).find("record length 20 is shorter than format 1's 28"),
            std::string::npos);
  std::string bad_offset = HandMadeLas12();
  Put<uint32_t>(&bad_offset, 96, 100);
  EXPECT_NE(ParseError(bad_offset).find("offset to point data 100"), std::string::npos);
  std::string zero_scale = HandMadeLas12();
  Put<double>(&zero_scale, 139, 0.0);
  EXPECT_NE(ParseError(zero_scale).find("scale/offset of y"), std::string::npos);
  EXPECT_NE(ParseError("PLY!").find("no 'LASF' signature"), std::string::npos);
  EXPECT_NE(
      ParseError(std::string("LASF") + std::string(100, '\0')).find("truncated public header"),
      std::string::npos);
  std::string v20 = HandMadeLas12();
  Put<uint8_t>(&v20, 24, 2);
  EXPECT_THROW(ParseLas(v20, "v20"), Error);
  try {
    ReadCloud("map.laz");
    FAIL() << "LAZ accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kUnsupported);
  }
  EXPECT_THROW(EncodeLas({{1e9f, 0, 0}, {-1e9f, 0, 0}}), Error);  // 2e9 m at mm: beyond int32
  EXPECT_THROW(EncodeLas({{NAN, 0, 0}}), Error);
}

}  // namespace
}  // namespace mapdelta
