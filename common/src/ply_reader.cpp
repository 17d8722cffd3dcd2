// PLY reader (ascii, binary_little_endian, binary_big_endian): the header is checked, elements
// before "vertex" are skipped property by property (lists included), and every read is
// bounds-checked so a truncated or lying file gives an error, not a crash.
#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <optional>
#include <sstream>
#include <vector>

#include "cloud_readers.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"

namespace mapdelta::detail {
namespace {

enum class Format { kAscii, kLittle, kBig };

struct Property {
  std::string name;
  char kind = 'f';  // 'i' signed, 'u' unsigned, 'f' floating
  int size = 4;
  bool is_list = false;
  char count_kind = 'u';
  int count_size = 1;
};

struct Element {
  std::string name;
  uint64_t count = 0;
  std::vector<Property> properties;
};

bool ScalarType(const std::string& name, char* kind, int* size) {
  static const struct {
    const char* name;
    char kind;
    int size;
  } kTypes[] = {{"char", 'i', 1},  {"int8", 'i', 1},    {"uchar", 'u', 1},  {"uint8", 'u', 1},
                {"short", 'i', 2}, {"int16", 'i', 2},   {"ushort", 'u', 2}, {"uint16", 'u', 2},
                {"int", 'i', 4},   {"int32", 'i', 4},   {"uint", 'u', 4},   {"uint32", 'u', 4},
                {"float", 'f', 4}, {"float32", 'f', 4}, {"double", 'f', 8}, {"float64", 'f', 8}};
  for (const auto& t : kTypes) {
    if (name == t.name) {
      *kind = t.kind;
      *size = t.size;
      return true;
    }
  }
  return false;
}

std::vector<std::string> Tokens(std::string_view line) {
  std::vector<std::string> out;
  std::istringstream in{std::string(line)};
  for (std::string token; in >> token;) out.push_back(token);
  return out;
}

// Sequential reader over the data section; throws naming the file when data runs out.
class DataCursor {
 public:
  DataCursor(std::string_view data, Format format, const std::string& path)
      : data_(data), format_(format), path_(path) {}

  double Scalar(char kind, int size) {
    if (format_ == Format::kAscii) return AsciiNumber();
    if (pos_ + static_cast<size_t>(size) > data_.size()) Truncated();
    unsigned char b[8];
    std::memcpy(b, data_.data() + pos_, size);
    pos_ += size;
    if ((format_ == Format::kBig) != (std::endian::native == std::endian::big))
      std::reverse(b, b + size);
    switch (size) {
      case 1:
        return kind == 'i' ? static_cast<double>(static_cast<int8_t>(b[0])) : b[0];
      case 2: {
        uint16_t u;
        std::memcpy(&u, b, 2);
        return kind == 'i' ? static_cast<int16_t>(u) : u;
      }
      case 4: {
        if (kind == 'f') {
          float f;
          std::memcpy(&f, b, 4);
          return f;
        }
        uint32_t u;
        std::memcpy(&u, b, 4);
        return kind == 'i' ? static_cast<double>(static_cast<int32_t>(u)) : u;
      }
      default: {
        double d;
        std::memcpy(&d, b, 8);
        return d;
      }
    }
  }
  size_t remaining() const { return data_.size() - std::min(pos_, data_.size()); }
  uint64_t element_index = 0;

 private:
  double AsciiNumber() {
    while (pos_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
    if (pos_ >= data_.size()) Truncated();
    size_t end = pos_;
    while (end < data_.size() && !std::isspace(static_cast<unsigned char>(data_[end]))) ++end;
    const std::string token(data_.substr(pos_, end - pos_));
    pos_ = end;
    char* parsed_end = nullptr;
    const double value = std::strtod(token.c_str(), &parsed_end);
    if (parsed_end != token.c_str() + token.size()) {
      throw Error(ErrorCode::kParse,
                  path_ + ": ascii data: '" + token.substr(0, 32) + "' is not a number");
    }
    return value;
  }
  [[noreturn]] void Truncated() const {
    throw Error(ErrorCode::kParse, path_ + ": truncated data (ran out at element " +
                                       std::to_string(element_index) +
                                       " of those the header declares)");
  }
  std::string_view data_;
  Format format_;
  const std::string& path_;
  size_t pos_ = 0;
};

void SkipElement(const Element& element, DataCursor* cursor, const std::string& path) {
  for (uint64_t i = 0; i < element.count; ++i) {
    cursor->element_index = i;
    for (const auto& p : element.properties) {
      if (!p.is_list) {
        cursor->Scalar(p.kind, p.size);
        continue;
      }
      const double n = cursor->Scalar(p.count_kind, p.count_size);
      if (!(n >= 0) || n > static_cast<double>(cursor->remaining())) {
        throw Error(ErrorCode::kParse,
                    path + ": element '" + element.name + "' has a list of invalid length");
      }
      for (uint64_t k = 0; k < static_cast<uint64_t>(n); ++k) cursor->Scalar(p.kind, p.size);
    }
  }
}

struct PlyHeader {
  Format format = Format::kAscii;
  std::vector<Element> elements;
};

// One 'property' line of the element being declared.
Property ParsePropertyLine(const std::vector<std::string>& t, HeaderReader& reader) {
  Property p;
  if (t.size() == 3 && ScalarType(t[1], &p.kind, &p.size)) {
    p.name = t[2];
  } else if (t.size() == 5 && t[1] == "list" && ScalarType(t[2], &p.count_kind, &p.count_size) &&
             p.count_kind != 'f' && ScalarType(t[3], &p.kind, &p.size)) {
    p.is_list = true;
    p.name = t[4];
  } else {
    reader.Fail("expected 'property <type> <name>' or 'property list <int type> <type> <name>'");
  }
  return p;
}

// The header up to end_header; the reader's offset is then where the data starts.
PlyHeader ParseHeader(HeaderReader& reader, const std::string& path) {
  std::string_view line;
  if (!reader.NextLine(&line) || line != "ply") {
    throw Error(ErrorCode::kParse, path + ": not a PLY file (first line must be 'ply')");
  }
  std::optional<Format> format;
  PlyHeader header;
  while (true) {
    if (!reader.NextLine(&line))
      throw Error(ErrorCode::kParse, path + ": PLY header has no end_header");
    const auto t = Tokens(line);
    if (t.empty() || t[0] == "comment" || t[0] == "obj_info") continue;
    if (t[0] == "end_header") break;
    if (t[0] == "format") {
      if (t.size() != 3 || t[2] != "1.0") reader.Fail("expected 'format <type> 1.0'");
      if (t[1] == "ascii")
        format = Format::kAscii;
      else if (t[1] == "binary_little_endian")
        format = Format::kLittle;
      else if (t[1] == "binary_big_endian")
        format = Format::kBig;
      else
        reader.Fail("unknown format '" + t[1].substr(0, 32) + "'");
    } else if (t[0] == "element") {
      Element e;
      if (t.size() != 3 || t[2].empty() || t[2].size() > 12 ||
          t[2].find_first_not_of("0123456789") != std::string::npos) {
        reader.Fail("expected 'element <name> <count>'");
      }
      e.name = t[1];
      e.count = std::stoull(t[2]);
      header.elements.push_back(e);
    } else if (t[0] == "property") {
      if (header.elements.empty()) reader.Fail("property before any element");
      header.elements.back().properties.push_back(ParsePropertyLine(t, reader));
    } else {
      reader.Fail("unknown PLY header keyword '" + t[0].substr(0, 32) + "'");
    }
  }
  if (!format) throw Error(ErrorCode::kParse, path + ": PLY header has no format line");
  header.format = *format;
  return header;
}

// Indices of the vertex element's scalar x, y and z properties; throws when one is missing.
std::array<int, 3> XyzProperties(const Element& vertex, const std::string& path) {
  std::array<int, 3> xyz = {-1, -1, -1};
  for (size_t i = 0; i < vertex.properties.size(); ++i) {
    const auto& p = vertex.properties[i];
    for (int axis = 0; axis < 3; ++axis) {
      if (!p.is_list && p.name == std::string(1, static_cast<char>('x' + axis)))
        xyz[axis] = static_cast<int>(i);
    }
  }
  if (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0) {
    throw Error(ErrorCode::kParse,
                path + ": PLY vertex element lacks scalar x, y and z properties");
  }
  return xyz;
}

// The vertices' positions (non-finite ones dropped), read from the cursor at the first vertex.
PrecisePointCloud ReadVertices(const Element& vertex, const std::array<int, 3>& xyz, Format format,
                               DataCursor* cursor, const std::string& path) {
  // Each vertex needs at least one byte per property (binary) or two characters (ascii).
  const uint64_t min_bytes = vertex.properties.size() * (format == Format::kAscii ? 2 : 1);
  if (vertex.count > cursor->remaining() / std::max<uint64_t>(min_bytes, 1) + 1) {
    throw Error(ErrorCode::kParse, path + ": header declares " + std::to_string(vertex.count) +
                                       " vertices but the file is too short for them");
  }
  PrecisePointCloud cloud;
  cloud.reserve(vertex.count);
  size_t dropped = 0;
  double v[3] = {0, 0, 0};
  for (uint64_t i = 0; i < vertex.count; ++i) {
    cursor->element_index = i;
    for (size_t k = 0; k < vertex.properties.size(); ++k) {
      const auto& p = vertex.properties[k];
      double value = 0;
      if (p.is_list) {
        const double n = cursor->Scalar(p.count_kind, p.count_size);
        if (!(n >= 0) || n > static_cast<double>(cursor->remaining())) {
          throw Error(ErrorCode::kParse,
                      path + ": vertex " + std::to_string(i) + " has a list of invalid length");
        }
        for (uint64_t j = 0; j < static_cast<uint64_t>(n); ++j) cursor->Scalar(p.kind, p.size);
      } else {
        value = cursor->Scalar(p.kind, p.size);
      }
      for (int axis = 0; axis < 3; ++axis) {
        if (xyz[axis] == static_cast<int>(k)) v[axis] = value;
      }
    }
    const PrecisePoint p(v[0], v[1], v[2]);
    if (p.allFinite())
      cloud.push_back(p);
    else
      ++dropped;
  }
  if (dropped > 0) MD_LOG(kDebug, path << ": dropped " << dropped << " non-finite points");
  return cloud;
}

}  // namespace

PrecisePointCloud ParsePly(std::string_view bytes, const std::string& path) {
  HeaderReader reader(bytes, path);
  const PlyHeader header = ParseHeader(reader, path);
  auto vertex = std::find_if(header.elements.begin(), header.elements.end(),
                             [](const Element& e) { return e.name == "vertex"; });
  if (vertex == header.elements.end())
    throw Error(ErrorCode::kParse, path + ": PLY header has no 'element vertex'");
  const std::array<int, 3> xyz = XyzProperties(*vertex, path);
  DataCursor cursor(bytes.substr(std::min(reader.offset(), bytes.size())), header.format, path);
  for (auto it = header.elements.begin(); it != vertex; ++it) SkipElement(*it, &cursor, path);
  return ReadVertices(*vertex, xyz, header.format, &cursor, path);
}

}  // namespace mapdelta::detail
