#include "mapdelta/common/cloud_io.hpp"

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "cloud_readers.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/las_io.hpp"

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

void WriteCloud(const std::string& path, const PointCloud& cloud) {
  const std::string ext = Extension(path);
  if (ext == ".las") {
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
  pcl_cloud.width = static_cast<uint32_t>(cloud.size());
  pcl_cloud.height = 1;
  int status = -1;
  if (ext == ".pcd") {
    if (cloud.empty()) {  // written here: PCL prints a warning to the console for empty clouds
      std::ofstream out(path);
      out << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\n"
             "TYPE F F F\nCOUNT 1 1 1\nWIDTH 0\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 0\n"
             "DATA ascii\n";
      status = out ? 0 : -1;
    } else {
      status = pcl::io::savePCDFileBinary(path, pcl_cloud);
    }
  } else if (ext == ".ply") {
    status = pcl::io::savePLYFileBinary(path, pcl_cloud);
  } else {
    throw Error(ErrorCode::kUnsupported,
                path + ": unsupported cloud format '" + ext + "' (expected .pcd, .ply or .las)");
  }
  if (status < 0) throw Error(ErrorCode::kIo, path + ": could not write cloud");
}

}  // namespace mapdelta
