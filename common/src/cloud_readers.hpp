#pragma once
// Our own PCD and PLY parsers (internal to mapdelta_common). PCL's readers trust the header
// and crash on truncated or garbage files; these check every count against the bytes present
// and throw Error(kParse) naming the file, the field and what was expected.
#include <array>
#include <string>
#include <string_view>

#include "mapdelta/common/point_cloud.hpp"
#include "mapdelta/common/precise_cloud.hpp"

namespace mapdelta::detail {

// `bytes` is the whole file; `path` only names it in errors. Non-finite points are dropped.
// Coordinates come back in double, as stored (float64 fields keep their precision). A PCD's
// VIEWPOINT (PCL's placement of the cloud: translation, then rotation w x y z) is not applied;
// `viewpoint`, if given, receives its seven values.
PrecisePointCloud ParsePcd(std::string_view bytes, const std::string& path,
                           std::array<double, 7>* viewpoint = nullptr);
PrecisePointCloud ParsePly(std::string_view bytes, const std::string& path);

// Reads the header line by line from the front of `bytes`; shared by both parsers.
class HeaderReader {
 public:
  HeaderReader(std::string_view bytes, const std::string& path) : bytes_(bytes), path_(path) {}
  // Next line without its end-of-line; false at end of data or when the header grows past
  // a sane size (a binary file with no header).
  bool NextLine(std::string_view* line);
  size_t offset() const { return offset_; }
  [[noreturn]] void Fail(const std::string& what) const;
  int line_number() const { return line_number_; }

 private:
  std::string_view bytes_;
  const std::string& path_;
  size_t offset_ = 0;
  int line_number_ = 0;
};

}  // namespace mapdelta::detail
