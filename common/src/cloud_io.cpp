#include "mapdelta/common/cloud_io.hpp"

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>
#include <pcl/register_point_struct.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "cloud_readers.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/las_io.hpp"

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

}  // namespace

PointCloud ReadCloud(const std::string& path) {
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
  if (ext == ".las") return ParseLas(bytes, path);
  return ext == ".pcd" ? detail::ParsePcd(bytes, path) : detail::ParsePly(bytes, path);
}

namespace {

// Binary PCD or PLY by extension. PCL refuses to write an empty PCD (and prints a warning to
// the console), but no points is a valid answer: its header comes from PCL, the data from here.
template <typename PclPoint>
void WritePclCloud(const std::string& path, pcl::PointCloud<PclPoint>& cloud) {
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
}

}  // namespace

void WriteCloud(const std::string& path, const PointCloud& cloud) {
  if (Extension(path) == ".las") {
    const std::string bytes = EncodeLas(cloud);
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) throw Error(ErrorCode::kIo, path + ": could not write cloud");
    return;
  }
  pcl::PointCloud<pcl::PointXYZ> pcl_cloud;
  pcl_cloud.resize(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    pcl_cloud[i] = pcl::PointXYZ(cloud[i].x(), cloud[i].y(), cloud[i].z());
  }
  WritePclCloud(path, pcl_cloud);
}

void WriteChangeCloud(const std::string& path, const std::vector<ChangeCloudPoint>& points) {
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
  WritePclCloud(path, pcl_cloud);
}

}  // namespace mapdelta
