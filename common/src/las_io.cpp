// LAS 1.2 / 1.4 reader and writer (las_io.hpp). Field offsets follow the ASPRS LAS
// specifications 1.2 (2008) and 1.4 R15 (2019), "Public Header Block"; all little-endian.
#include "mapdelta/common/las_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "mapdelta/common/error.hpp"

namespace mapdelta {
namespace {

// Header field offsets (bytes from the file start).
constexpr size_t kVersionMajor = 24, kVersionMinor = 25, kHeaderSize = 94, kPointDataOffset = 96,
                 kVlrCount = 100, kPointFormat = 104, kRecordLength = 105, kLegacyPointCount = 107,
                 kLegacyByReturn = 111, kScale = 131, kOffset = 155, kMaxX = 179,
                 kPointCount14 = 247, kByReturn14 = 255;
constexpr size_t kHeaderSize12 = 227, kHeaderSize14 = 375;
// The shortest record of point formats 0..10 (spec table "Point Data Record Format").
constexpr uint16_t kMinRecordLength[] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};

template <typename T>
T Get(std::string_view bytes, size_t at) {
  T v;
  std::memcpy(&v, bytes.data() + at, sizeof(T));  // x86-64 and aarch64 Linux are little-endian
  return v;
}

template <typename T>
void Put(std::string* out, size_t at, T v) {
  std::memcpy(out->data() + at, &v, sizeof(T));
}

[[noreturn]] void Fail(const std::string& path, const std::string& what) {
  throw Error(ErrorCode::kParse, path + ": " + what);
}

}  // namespace

PrecisePointCloud ParseLasPrecise(std::string_view bytes, const std::string& path) {
  if (bytes.size() < 4 || bytes.substr(0, 4) != "LASF")
    Fail(path, "not a LAS file (no 'LASF' signature)");
  if (bytes.size() < kHeaderSize12)
    Fail(path, "truncated public header (" + std::to_string(bytes.size()) + " bytes)");
  const int major = Get<uint8_t>(bytes, kVersionMajor), minor = Get<uint8_t>(bytes, kVersionMinor);
  if (major != 1 || minor > 4) {
    throw Error(ErrorCode::kUnsupported, path + ": LAS version " + std::to_string(major) + "." +
                                             std::to_string(minor) + " (expected 1.0-1.4)");
  }
  const uint16_t header_size = Get<uint16_t>(bytes, kHeaderSize);
  const size_t expected_header = minor >= 4 ? kHeaderSize14 : kHeaderSize12;
  if (header_size < expected_header || header_size > bytes.size()) {
    Fail(path, "header size " + std::to_string(header_size) + " (LAS 1." + std::to_string(minor) +
                   " needs >= " + std::to_string(expected_header) + " within the file)");
  }
  const uint8_t format_byte = Get<uint8_t>(bytes, kPointFormat);
  if (format_byte & 0xC0) {
    throw Error(ErrorCode::kUnsupported,
                path + ": LAZ (compressed LAS, point format byte " + std::to_string(format_byte) +
                    ") is not supported: decompress it to .las first (e.g. laszip)");
  }
  if (format_byte > 10)
    Fail(path, "point data format " + std::to_string(format_byte) + " (expected 0-10)");
  const uint16_t record_length = Get<uint16_t>(bytes, kRecordLength);
  if (record_length < kMinRecordLength[format_byte]) {
    Fail(path, "point data record length " + std::to_string(record_length) +
                   " is shorter than format " + std::to_string(format_byte) + "'s " +
                   std::to_string(kMinRecordLength[format_byte]));
  }
  uint64_t count = Get<uint32_t>(bytes, kLegacyPointCount);
  if (minor >= 4) {
    const uint64_t count64 = Get<uint64_t>(bytes, kPointCount14);
    if (count != 0 && count != count64) {
      Fail(path, "legacy point count " + std::to_string(count) + " disagrees with the 1.4 count " +
                     std::to_string(count64));
    }
    count = count64;
  }
  const uint32_t data_offset = Get<uint32_t>(bytes, kPointDataOffset);
  if (data_offset < header_size || data_offset > bytes.size()) {
    Fail(path, "offset to point data " + std::to_string(data_offset) + " is outside [header size " +
                   std::to_string(header_size) + ", file size " + std::to_string(bytes.size()) +
                   "]");
  }
  if (count > (bytes.size() - data_offset) / record_length) {
    Fail(path, "header says " + std::to_string(count) + " points of " +
                   std::to_string(record_length) + " bytes, the file holds " +
                   std::to_string((bytes.size() - data_offset) / record_length));
  }
  double scale[3], offset[3];
  for (int a = 0; a < 3; ++a) {
    scale[a] = Get<double>(bytes, kScale + 8 * a);
    offset[a] = Get<double>(bytes, kOffset + 8 * a);
    if (!std::isfinite(scale[a]) || scale[a] == 0 || !std::isfinite(offset[a])) {
      Fail(path, std::string("scale/offset of ") + "xyz"[a] + " is not a finite, non-zero scale");
    }
  }
  PrecisePointCloud cloud;
  cloud.reserve(count);
  for (uint64_t i = 0; i < count; ++i) {
    const size_t at = data_offset + i * record_length;
    PrecisePoint p;
    for (int a = 0; a < 3; ++a) p[a] = Get<int32_t>(bytes, at + 4 * a) * scale[a] + offset[a];
    cloud.push_back(p);
  }
  return cloud;
}

PointCloud ParseLas(std::string_view bytes, const std::string& path) {
  return ToFloat(ParseLasPrecise(bytes, path));
}

std::string EncodeLas(const PointCloud& cloud, const LasWriteOptions& options) {
  if (options.minor_version != 2 && options.minor_version != 4) {
    throw Error(ErrorCode::kInvalidArgument, "LAS writer: minor version must be 2 or 4");
  }
  if (!(options.scale_m > 0) || !std::isfinite(options.scale_m)) {
    throw Error(ErrorCode::kInvalidArgument, "LAS writer: scale must be a positive number");
  }
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud[i].allFinite())
      throw Error(ErrorCode::kInvalidArgument,
                  "LAS writer: point " + std::to_string(i) + " is not finite");
  }
  if (options.minor_version == 2 && cloud.size() > std::numeric_limits<uint32_t>::max()) {
    throw Error(ErrorCode::kInvalidArgument, "LAS writer: LAS 1.2 holds at most 2^32-1 points");
  }
  const bool v14 = options.minor_version == 4;
  const size_t header_size = v14 ? kHeaderSize14 : kHeaderSize12;
  const uint16_t record_length = v14 ? 30 : 20;
  const AxisAlignedBox box = Bounds(cloud);
  double offset[3], lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    offset[a] = std::floor(box.min[a]);
    lo[a] = box.min[a];
    hi[a] = box.max[a];
    const double span = (hi[a] - offset[a]) / options.scale_m;
    if (!cloud.empty() && !(span < std::numeric_limits<int32_t>::max())) {
      throw Error(ErrorCode::kInvalidArgument, std::string("LAS writer: ") + "xyz"[a] +
                                                   " extent does not fit int32 at scale " +
                                                   std::to_string(options.scale_m) + " m");
    }
  }
  std::string out(header_size + cloud.size() * record_length, '\0');
  // 1. Public header.
  std::memcpy(out.data(), "LASF", 4);
  Put<uint8_t>(&out, kVersionMajor, 1);
  Put<uint8_t>(&out, kVersionMinor, static_cast<uint8_t>(options.minor_version));
  std::memcpy(out.data() + 26, "mapdelta", 8);          // system identifier (32 chars)
  std::memcpy(out.data() + 58, "mapdelta las_io", 15);  // generating software (32 chars)
  Put<uint16_t>(&out, kHeaderSize, static_cast<uint16_t>(header_size));
  Put<uint32_t>(&out, kPointDataOffset, static_cast<uint32_t>(header_size));
  Put<uint32_t>(&out, kVlrCount, 0);
  Put<uint8_t>(&out, kPointFormat, v14 ? 6 : 0);
  Put<uint16_t>(&out, kRecordLength, record_length);
  // Every point is a single return (return 1 of 1). Point formats 6-10 keep the legacy
  // counts at zero (LAS 1.4: the 64-bit counts below are the ones).
  const auto legacy_count = static_cast<uint32_t>(v14 ? 0 : cloud.size());
  Put<uint32_t>(&out, kLegacyPointCount, legacy_count);
  Put<uint32_t>(&out, kLegacyByReturn, legacy_count);
  for (int a = 0; a < 3; ++a) {
    Put<double>(&out, kScale + 8 * a, options.scale_m);
    Put<double>(&out, kOffset + 8 * a, offset[a]);
    Put<double>(&out, kMaxX + 16 * a, hi[a]);  // max x, min x, max y, min y, max z, min z
    Put<double>(&out, kMaxX + 16 * a + 8, lo[a]);
  }
  if (v14) {
    Put<uint64_t>(&out, kPointCount14, cloud.size());
    Put<uint64_t>(&out, kByReturn14, cloud.size());
  }
  // 2. Point records: X Y Z, then format 0's "return 1 of 1" bits (3 + 3) in byte 14, or
  // format 6's return number (4 bits) and number of returns (4 bits) in byte 14.
  for (size_t i = 0; i < cloud.size(); ++i) {
    const size_t at = header_size + i * record_length;
    for (int a = 0; a < 3; ++a) {
      Put<int32_t>(&out, at + 4 * a,
                   static_cast<int32_t>(std::llround((cloud[i][a] - offset[a]) / options.scale_m)));
    }
    Put<uint8_t>(&out, at + 14, v14 ? 0x11 : 0x09);
  }
  return out;
}

}  // namespace mapdelta
