// PCD v0.5-0.7 reader: header checked field by field, then ascii, binary or binary_compressed
// (LZF) data with every size checked against the bytes present.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <vector>

#include "cloud_readers.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"

namespace mapdelta::detail {
namespace {

constexpr size_t kMaxHeaderBytes = 1 << 16;
constexpr uint64_t kMaxPoints = uint64_t{1} << 34;  // far above any real cloud, below overflow

std::vector<std::string> Tokens(std::string_view line) {
  std::vector<std::string> out;
  std::istringstream in{std::string(line)};
  for (std::string token; in >> token;) out.push_back(token);
  return out;
}

bool ParseUint(const std::string& text, uint64_t* value) {
  if (text.empty() || text.size() > 12) return false;
  uint64_t v = 0;
  for (char c : text) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + static_cast<uint64_t>(c - '0');
  }
  *value = v;
  return true;
}

struct Field {
  std::string name;
  uint64_t size = 0;
  char type = 0;
  uint64_t count = 1;
  uint64_t offset = 0;       // byte offset within one packed point
  uint64_t value_index = 0;  // position of its first value on an ascii line
};

struct PcdHeader {
  std::vector<Field> fields;
  uint64_t width = 0, height = 0, points = 0;
  std::string data;
  size_t data_offset = 0;
  uint64_t point_size = 0;
  int xyz[3] = {-1, -1, -1};
  std::array<double, 7> viewpoint = {0, 0, 0, 1, 0, 0, 0};  // PCL's default
};

// One value of type T stored at p (unaligned), as a double.
template <typename T>
double Load(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return static_cast<double>(v);
}

// Converts one value of a field stored at p (little-endian host, as PCL writes it); the header
// check allows sizes 4 and 8 for F and 1, 2, 4 and 8 for I and U.
double ReadValue(const char* p, const Field& f) {
  switch (f.type) {
    case 'F':
      return f.size == 4 ? Load<float>(p) : Load<double>(p);
    case 'I':
      switch (f.size) {
        case 1:
          return Load<int8_t>(p);
        case 2:
          return Load<int16_t>(p);
        case 4:
          return Load<int32_t>(p);
        default:
          return Load<int64_t>(p);
      }
    default:
      switch (f.size) {
        case 1:
          return Load<uint8_t>(p);
        case 2:
          return Load<uint16_t>(p);
        case 4:
          return Load<uint32_t>(p);
        default:
          return Load<uint64_t>(p);
      }
  }
}

PcdHeader ParseHeader(std::string_view bytes, const std::string& path) {
  HeaderReader reader(bytes, path);
  PcdHeader h;
  std::vector<std::string> sizes, types, counts;
  bool have_width = false, have_height = false, have_points = false;
  std::string_view line;
  while (h.data.empty()) {
    if (!reader.NextLine(&line)) {
      throw Error(ErrorCode::kParse, path + ": not a PCD file (header has no DATA line)");
    }
    const auto t = Tokens(line);
    if (t.empty() || t[0][0] == '#') continue;
    const std::string& key = t[0];
    const std::vector<std::string> values(t.begin() + 1, t.end());
    const auto one_uint = [&](uint64_t* v) {
      if (values.size() != 1 || !ParseUint(values[0], v))
        reader.Fail(key + " must be one non-negative integer");
    };
    if (key == "VERSION") {
      if (values.size() != 1) reader.Fail("VERSION must have one value");
    } else if (key == "FIELDS" || key == "COLUMNS") {
      if (values.empty()) reader.Fail("FIELDS lists no fields");
      for (const auto& name : values) h.fields.push_back({name});
    } else if (key == "SIZE") {
      sizes = values;
    } else if (key == "TYPE") {
      types = values;
    } else if (key == "COUNT") {
      counts = values;
    } else if (key == "WIDTH") {
      one_uint(&h.width);
      have_width = true;
    } else if (key == "HEIGHT") {
      one_uint(&h.height);
      have_height = true;
    } else if (key == "POINTS") {
      one_uint(&h.points);
      have_points = true;
    } else if (key == "VIEWPOINT") {
      if (values.size() != 7) reader.Fail("VIEWPOINT must have 7 values");
      for (size_t k = 0; k < 7; ++k) {
        char* end = nullptr;
        h.viewpoint[k] = std::strtod(values[k].c_str(), &end);
        if (end != values[k].c_str() + values[k].size() || !std::isfinite(h.viewpoint[k]))
          reader.Fail("VIEWPOINT value " + std::to_string(k + 1) + " is not a finite number");
      }
    } else if (key == "DATA") {
      if (values.size() != 1 ||
          (values[0] != "ascii" && values[0] != "binary" && values[0] != "binary_compressed")) {
        reader.Fail("DATA must be ascii, binary or binary_compressed");
      }
      h.data = values[0];
    } else {
      reader.Fail("unknown PCD header keyword '" + key.substr(0, 32) + "'");
    }
  }
  h.data_offset = reader.offset();
  if (h.fields.empty()) reader.Fail("missing FIELDS");
  const size_t n = h.fields.size();
  if (sizes.size() != n) reader.Fail("SIZE needs " + std::to_string(n) + " values (one per field)");
  if (types.size() != n) reader.Fail("TYPE needs " + std::to_string(n) + " values (one per field)");
  if (!counts.empty() && counts.size() != n)
    reader.Fail("COUNT needs " + std::to_string(n) + " values");
  if (!have_width || !have_height) reader.Fail("missing WIDTH or HEIGHT");
  if (h.width > kMaxPoints || h.height > kMaxPoints || h.width * h.height > kMaxPoints) {
    reader.Fail("WIDTH x HEIGHT is implausibly large");
  }
  if (!have_points) h.points = h.width * h.height;
  if (h.points != h.width * h.height) reader.Fail("POINTS differs from WIDTH x HEIGHT");
  for (size_t i = 0; i < n; ++i) {
    Field& f = h.fields[i];
    if (!ParseUint(sizes[i], &f.size) ||
        (f.size != 1 && f.size != 2 && f.size != 4 && f.size != 8)) {
      reader.Fail("SIZE of field '" + f.name + "' must be 1, 2, 4 or 8");
    }
    if (types[i].size() != 1 || (types[i][0] != 'F' && types[i][0] != 'I' && types[i][0] != 'U')) {
      reader.Fail("TYPE of field '" + f.name + "' must be F, I or U");
    }
    f.type = types[i][0];
    if (f.type == 'F' && f.size != 4 && f.size != 8) reader.Fail("TYPE F needs SIZE 4 or 8");
    if (!counts.empty() && (!ParseUint(counts[i], &f.count) || f.count == 0 || f.count > 4096)) {
      reader.Fail("COUNT of field '" + f.name + "' must be 1..4096");
    }
    f.offset = h.point_size;
    h.point_size += f.size * f.count;
    f.value_index = i == 0 ? 0 : h.fields[i - 1].value_index + h.fields[i - 1].count;
    for (int axis = 0; axis < 3; ++axis) {
      if (f.name == std::string(1, static_cast<char>('x' + axis)))
        h.xyz[axis] = static_cast<int>(i);
    }
  }
  if (h.xyz[0] < 0 || h.xyz[1] < 0 || h.xyz[2] < 0) reader.Fail("FIELDS must include x, y and z");
  return h;
}

// LZF (liblzf format, as PCL writes it); every read and back-reference is bounds-checked.
bool LzfDecompress(const unsigned char* in, size_t in_size, unsigned char* out, size_t out_size) {
  size_t ip = 0, op = 0;
  while (ip < in_size) {
    size_t ctrl = in[ip++];
    if (ctrl < 32) {  // literal run of ctrl + 1 bytes
      const size_t len = ctrl + 1;
      if (ip + len > in_size || op + len > out_size) return false;
      std::memcpy(out + op, in + ip, len);
      ip += len;
      op += len;
    } else {  // back reference
      size_t len = ctrl >> 5;
      if (len == 7) {
        if (ip >= in_size) return false;
        len += in[ip++];
      }
      if (ip >= in_size) return false;
      const size_t distance = ((ctrl & 0x1f) << 8) + in[ip++] + 1;
      len += 2;
      if (distance > op || op + len > out_size) return false;
      for (size_t k = 0; k < len; ++k, ++op) out[op] = out[op - distance];  // may overlap
    }
  }
  return op == out_size;
}

void Append(PrecisePointCloud* cloud, double x, double y, double z, size_t* dropped) {
  const PrecisePoint p(x, y, z);
  if (p.allFinite())
    cloud->push_back(p);
  else
    ++*dropped;
}

}  // namespace

PrecisePointCloud ParsePcd(std::string_view bytes, const std::string& path,
                           std::array<double, 7>* viewpoint) {
  const PcdHeader h = ParseHeader(bytes, path);
  if (viewpoint) *viewpoint = h.viewpoint;
  const std::string_view data = bytes.substr(std::min(h.data_offset, bytes.size()));
  const uint64_t n = h.points;
  const Field* f[3] = {&h.fields[h.xyz[0]], &h.fields[h.xyz[1]], &h.fields[h.xyz[2]]};
  const auto short_data = [&](uint64_t need, uint64_t have) {
    return Error(ErrorCode::kParse, path + ": truncated " + h.data + " data: header says " +
                                        std::to_string(n) + " points (" + std::to_string(need) +
                                        " bytes), file has " + std::to_string(have) + " bytes");
  };
  PrecisePointCloud cloud;
  size_t dropped = 0;
  if (h.data == "ascii") {
    uint64_t total_values = 0;
    for (const auto& field : h.fields) total_values += field.count;
    cloud.reserve(std::min<uint64_t>(n, data.size() / 6 + 1));
    std::vector<double> values(total_values);
    size_t pos = 0;
    for (uint64_t read = 0; read < n;) {
      if (pos >= data.size()) {
        throw Error(ErrorCode::kParse, path + ": ascii data has " + std::to_string(read) +
                                           " points, header says " + std::to_string(n));
      }
      size_t end = data.find('\n', pos);
      if (end == std::string_view::npos) end = data.size();
      const auto t = Tokens(data.substr(pos, end - pos));
      pos = end + 1;
      if (t.empty()) continue;
      if (t.size() != total_values) {
        throw Error(ErrorCode::kParse, path + ": ascii point " + std::to_string(read + 1) +
                                           " has " + std::to_string(t.size()) +
                                           " values, expected " + std::to_string(total_values));
      }
      double xyz[3];
      for (int axis = 0; axis < 3; ++axis) {
        const std::string& token = t[f[axis]->value_index];
        char* parsed_end = nullptr;
        xyz[axis] = std::strtod(token.c_str(), &parsed_end);
        if (parsed_end != token.c_str() + token.size()) {
          throw Error(ErrorCode::kParse, path + ": ascii point " + std::to_string(read + 1) +
                                             ": '" + token.substr(0, 32) + "' is not a number");
        }
      }
      Append(&cloud, xyz[0], xyz[1], xyz[2], &dropped);
      ++read;
    }
  } else if (h.data == "binary") {
    const uint64_t need = n * h.point_size;
    if (need > data.size()) throw short_data(need, data.size());
    cloud.reserve(n);
    for (uint64_t i = 0; i < n; ++i) {
      const char* point = data.data() + i * h.point_size;
      Append(&cloud, ReadValue(point + f[0]->offset, *f[0]), ReadValue(point + f[1]->offset, *f[1]),
             ReadValue(point + f[2]->offset, *f[2]), &dropped);
    }
  } else {  // binary_compressed: two uint32 sizes, then LZF of the fields stored column by column
    if (data.size() < 8) throw short_data(8, data.size());
    uint32_t compressed = 0, uncompressed = 0;
    std::memcpy(&compressed, data.data(), 4);
    std::memcpy(&uncompressed, data.data() + 4, 4);
    const uint64_t need = n * h.point_size;
    if (uncompressed != need) {
      throw Error(ErrorCode::kParse, path + ": binary_compressed data unpacks to " +
                                         std::to_string(uncompressed) + " bytes, header implies " +
                                         std::to_string(need));
    }
    if (uint64_t{compressed} + 8 > data.size())
      throw short_data(uint64_t{compressed} + 8, data.size());
    std::vector<unsigned char> raw(need);
    if (need > 0 && !LzfDecompress(reinterpret_cast<const unsigned char*>(data.data()) + 8,
                                   compressed, raw.data(), raw.size())) {
      throw Error(ErrorCode::kParse, path + ": binary_compressed data is corrupt (LZF)");
    }
    cloud.reserve(n);
    const auto column = [&](const Field& field, uint64_t i) {
      return reinterpret_cast<const char*>(raw.data()) + n * field.offset +
             i * field.size * field.count;
    };
    for (uint64_t i = 0; i < n; ++i) {
      Append(&cloud, ReadValue(column(*f[0], i), *f[0]), ReadValue(column(*f[1], i), *f[1]),
             ReadValue(column(*f[2], i), *f[2]), &dropped);
    }
  }
  if (dropped > 0) MD_LOG(kDebug, path << ": dropped " << dropped << " non-finite points");
  return cloud;
}

bool HeaderReader::NextLine(std::string_view* line) {
  if (offset_ >= bytes_.size() || offset_ > kMaxHeaderBytes) return false;
  size_t end = bytes_.find('\n', offset_);
  if (end == std::string_view::npos) end = bytes_.size();
  if (end - offset_ > kMaxHeaderBytes) return false;
  *line = bytes_.substr(offset_, end - offset_);
  if (!line->empty() && line->back() == '\r') line->remove_suffix(1);
  offset_ = end + 1;
  ++line_number_;
  return true;
}

void HeaderReader::Fail(const std::string& what) const {
  throw Error(ErrorCode::kParse,
              path_ + ": header line " + std::to_string(line_number_) + ": " + what);
}

}  // namespace mapdelta::detail
