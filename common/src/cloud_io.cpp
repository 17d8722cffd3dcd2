#include "mapdelta/common/cloud_io.hpp"

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>
#include <pcl/register_point_struct.h>

#include <array>
#include <bit>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "cloud_readers.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/las_io.hpp"
#include "mapdelta/common/number_text.hpp"

// PCL's layout of ChangeCloudPoint: the field names are what readers see.
namespace mapdelta::detail {
struct PclChangePoint {
  PCL_ADD_POINT4D;  // x y z and a padding float, which PCL's writers leave out
  float confidence;
  uint32_t observed_by;
  uint32_t supported_by;
  PCL_MAKE_ALIGNED_OPERATOR_NEW
};
}  // namespace mapdelta::detail

// clang-format off
POINT_CLOUD_REGISTER_POINT_STRUCT(mapdelta::detail::PclChangePoint,
    (float, x, x)(float, y, y)(float, z, z)(float, confidence, confidence)
    (uint32_t, observed_by, observed_by)(uint32_t, supported_by, supported_by))
// clang-format on

namespace mapdelta {
namespace {

std::string Extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (auto& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// The whole file, after checking its extension names a format we read.
std::string ReadCloudBytes(const std::string& path) {
  const std::string ext = Extension(path);
  if (ext == ".laz") {
    throw Error(ErrorCode::kUnsupported,
                path +
                    ": LAZ (compressed LAS) is not supported: decompress it to .las "
                    "first (e.g. laszip); see las_io.hpp");
  }
  if (ext != ".pcd" && ext != ".ply" && ext != ".las") {
    throw Error(ErrorCode::kUnsupported,
                path + ": unsupported cloud format '" + ext + "' (expected .pcd, .ply or .las)");
  }
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw Error(ErrorCode::kIo, path + ": no such file");
  }
  // Whole file in memory: the parsers check every declared size against what is present
  // (PCL's readers do not, and crash on garbage; see cloud_readers.hpp).
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw Error(ErrorCode::kIo, path + ": read failed");
  return bytes;
}

}  // namespace

PointCloud ReadCloud(const std::string& path) {
  const std::string bytes = ReadCloudBytes(path);
  const std::string ext = Extension(path);
  if (ext == ".las") return ParseLas(bytes, path);
  return ToFloat(ext == ".pcd" ? detail::ParsePcd(bytes, path) : detail::ParsePly(bytes, path));
}

PrecisePointCloud ReadCloudPrecise(const std::string& path) {
  const std::string bytes = ReadCloudBytes(path);
  const std::string ext = Extension(path);
  if (ext == ".las") return ParseLasPrecise(bytes, path);
  if (ext == ".ply") return detail::ParsePly(bytes, path);
  std::array<double, 7> viewpoint{};
  PrecisePointCloud cloud = detail::ParsePcd(bytes, path, &viewpoint);
  if (viewpoint[3] != 1 || viewpoint[4] != 0 || viewpoint[5] != 0 || viewpoint[6] != 0) {
    throw Error(ErrorCode::kUnsupported,
                path +
                    ": VIEWPOINT has a rotation (expected 'tx ty tz 1 0 0 0'); rotate the "
                    "points themselves before importing");
  }
  const Eigen::Vector3d t(viewpoint[0], viewpoint[1], viewpoint[2]);
  for (auto& p : cloud) p += t;
  return cloud;
}

namespace {

// PCL keeps a cloud's viewpoint in float32 (sensor_origin_), which would round a UTM origin to
// 0.5 m: the VIEWPOINT line PCL wrote is replaced by the exact origin, and the CRS goes into a
// comment line (PCL's and our readers skip lines starting with '#').
void PlaceWrittenPcd(const std::string& path, const CloudFrame& frame) {
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  const size_t viewpoint = bytes.find("\nVIEWPOINT ");
  const size_t line_end =
      viewpoint == std::string::npos ? viewpoint : bytes.find('\n', viewpoint + 1);
  if (line_end == std::string::npos) throw Error(ErrorCode::kIo, path + ": PCD without VIEWPOINT");
  std::string header = "\n";
  if (!frame.crs.empty()) header += "# crs " + frame.crs + "\n";
  header += "VIEWPOINT " + ShortestNumber(frame.origin.x()) + " " +
            ShortestNumber(frame.origin.y()) + " " + ShortestNumber(frame.origin.z()) + " 1 0 0 0";
  bytes.replace(viewpoint, line_end - viewpoint, header);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) throw Error(ErrorCode::kIo, path + ": could not write cloud");
}

// Binary PCD or PLY by extension. PCL refuses to write an empty PCD (and prints a warning to
// the console), but no points is a valid answer: its header comes from PCL, the data from here.
template <typename PclPoint>
void WritePclCloud(const std::string& path, pcl::PointCloud<PclPoint>& cloud,
                   const CloudFrame& frame) {
  cloud.width = static_cast<uint32_t>(cloud.size());
  cloud.height = 1;
  const std::string ext = Extension(path);
  int status = -1;
  if (ext == ".pcd" && cloud.empty()) {
    std::ofstream out(path);
    out << pcl::PCDWriter::generateHeader(cloud, 0) << "DATA ascii\n";
    status = out ? 0 : -1;
  } else if (ext == ".pcd") {
    status = pcl::io::savePCDFileBinary(path, cloud);
  } else if (ext == ".ply") {
    status = pcl::io::savePLYFileBinary(path, cloud);
  } else {
    throw Error(ErrorCode::kUnsupported,
                path + ": unsupported cloud format '" + ext + "' (expected .pcd, .ply or .las)");
  }
  if (status < 0) throw Error(ErrorCode::kIo, path + ": could not write cloud");
  if (ext == ".pcd" && !frame.IsLocal()) PlaceWrittenPcd(path, frame);
}

// A binary little-endian PLY whose vertices start with float64 x y z in user coordinates,
// followed by `extra` scalar properties ("float confidence", ...). Our own writer: PCL's point
// types are float32, and a double PLY is what PDAL, CloudCompare and Open3D read exactly.
// `vertex(i, out)` appends vertex i's extra property bytes.
template <typename Vertex>
void WriteUserPly(const std::string& path, size_t count, const CloudFrame& frame,
                  const std::vector<std::string>& extra, Vertex vertex) {
  std::string out = "ply\nformat binary_little_endian 1.0\n";
  if (!frame.crs.empty()) out += "comment crs " + frame.crs + "\n";
  out += "element vertex " + std::to_string(count) +
         "\nproperty double x\nproperty double y\nproperty double z\n";
  for (const std::string& p : extra) out += "property " + p + "\n";
  out += "end_header\n";
  for (size_t i = 0; i < count; ++i) vertex(i, &out);
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file.write(out.data(), static_cast<std::streamsize>(out.size()));
  file.close();
  if (!file) throw Error(ErrorCode::kIo, path + ": could not write cloud");
}

template <typename T>
void AppendBytes(std::string* out, T value) {
  static_assert(std::endian::native == std::endian::little, "PLY is written little-endian");
  out->append(reinterpret_cast<const char*>(&value), sizeof(value));
}

void AppendUserXyz(std::string* out, const Point& local, const CloudFrame& frame) {
  const Eigen::Vector3d user = local.cast<double>() + frame.origin;
  for (int a = 0; a < 3; ++a) AppendBytes(out, user[a]);
}

bool IsUserPly(const std::string& path, const CloudFrame& frame) {
  return Extension(path) == ".ply" && !frame.IsLocal();
}

}  // namespace

void WriteCloud(const std::string& path, const PointCloud& cloud, const CloudFrame& frame) {
  if (Extension(path) == ".las") {
    if (!frame.IsLocal())
      throw Error(ErrorCode::kUnsupported, path + ": LAS is written in local coordinates only");
    const std::string bytes = EncodeLas(cloud);
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) throw Error(ErrorCode::kIo, path + ": could not write cloud");
    return;
  }
  if (IsUserPly(path, frame)) {
    WriteUserPly(path, cloud.size(), frame, {},
                 [&](size_t i, std::string* out) { AppendUserXyz(out, cloud[i], frame); });
    return;
  }
  pcl::PointCloud<pcl::PointXYZ> pcl_cloud;
  pcl_cloud.resize(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    pcl_cloud[i] = pcl::PointXYZ(cloud[i].x(), cloud[i].y(), cloud[i].z());
  }
  WritePclCloud(path, pcl_cloud, frame);
}

void WriteChangeCloud(const std::string& path, const std::vector<ChangeCloudPoint>& points,
                      const CloudFrame& frame) {
  if (IsUserPly(path, frame)) {
    WriteUserPly(path, points.size(), frame,
                 {"float confidence", "uint observed_by", "uint supported_by"},
                 [&](size_t i, std::string* out) {
                   AppendUserXyz(out, points[i].position, frame);
                   AppendBytes(out, points[i].confidence);
                   AppendBytes(out, points[i].observed_by);
                   AppendBytes(out, points[i].supported_by);
                 });
    return;
  }
  pcl::PointCloud<detail::PclChangePoint> pcl_cloud;
  pcl_cloud.resize(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    detail::PclChangePoint& p = pcl_cloud[i];
    p.x = points[i].position.x();
    p.y = points[i].position.y();
    p.z = points[i].position.z();
    p.data[3] = 1;
    p.confidence = points[i].confidence;
    p.observed_by = points[i].observed_by;
    p.supported_by = points[i].supported_by;
  }
  WritePclCloud(path, pcl_cloud, frame);
}

}  // namespace mapdelta
