// ObservedArea persistence: OctoMap's .bt format, validated in full before OctoMap parses it
// (OctoMap's reader trusts the stream: a truncated or forged one can make it allocate nodes
// from uninitialised bytes).
#include <cmath>
#include <fstream>
#include <iterator>
#include <sstream>

#include "mapdelta/common/error.hpp"
#include "observed_area_impl.hpp"

namespace mapdelta {
namespace detail {
namespace {

constexpr std::string_view kHeader = "# Octomap OcTree binary file";
constexpr int kTreeDepth = 16;

struct BitStream {
  std::string_view data;
  size_t pos = 0;
  uint64_t nodes = 1;  // the root
};

// Mirrors OccupancyOcTreeBase::readBinaryNode: two bytes per node, two bits per child
// (00 unknown, 01 occupied leaf, 10 free leaf, 11 inner node followed recursively).
bool WalkNode(BitStream* s, int depth, std::string* problem) {
  if (s->pos + 2 > s->data.size()) {
    *problem = "node data ends early";
    return false;
  }
  const auto lo = static_cast<unsigned char>(s->data[s->pos]);
  const auto hi = static_cast<unsigned char>(s->data[s->pos + 1]);
  s->pos += 2;
  const unsigned bits = lo | (hi << 8);
  for (int child = 0; child < 8; ++child) {
    const unsigned code = (bits >> (2 * child)) & 3u;
    if (code == 0) continue;
    ++s->nodes;
    if (code != 3) continue;
    if (depth + 1 >= kTreeDepth) {
      *problem = "inner node below the deepest level";
      return false;
    }
    if (!WalkNode(s, depth + 1, problem)) return false;
  }
  return true;
}

}  // namespace

double ValidateOctomapBinary(std::string_view bytes, const std::string& what) {
  const auto fail = [&](const std::string& problem) {
    return Error(ErrorCode::kParse, what + ": not a valid OctoMap binary (.bt) tree: " + problem);
  };
  if (bytes.substr(0, kHeader.size()) != kHeader)
    throw fail("first line must be '" + std::string(kHeader) + "'");
  size_t pos = 0;
  std::string id;
  double resolution = 0;
  long long size = -1;
  bool data = false;
  while (!data) {
    const size_t end = bytes.find('\n', pos);
    if (end == std::string_view::npos || end - pos > 1024) throw fail("header has no 'data' line");
    std::istringstream line{std::string(bytes.substr(pos, end - pos))};
    pos = end + 1;
    std::string key;
    line >> key;
    if (key.empty() || key[0] == '#') continue;
    if (key == "id")
      line >> id;
    else if (key == "res")
      line >> resolution;
    else if (key == "size")
      line >> size;
    else if (key == "data")
      data = true;
    else
      throw fail("unknown header keyword '" + key.substr(0, 32) + "'");
    if (!data && line.fail()) throw fail("bad value for '" + key + "'");
  }
  if (id != "OcTree") throw fail("id must be 'OcTree' (got '" + id.substr(0, 32) + "')");
  if (!(std::isfinite(resolution) && resolution >= 1e-3)) throw fail("res must be >= 0.001");
  if (size < 0) throw fail("missing 'size'");
  BitStream stream{bytes.substr(pos)};
  if (size == 0) {
    if (!stream.data.empty()) throw fail("size 0 but node data follows");
    return resolution;
  }
  std::string problem;
  if (!WalkNode(&stream, 0, &problem)) throw fail(problem);
  if (stream.pos != stream.data.size()) throw fail("trailing bytes after the node data");
  if (stream.nodes != static_cast<uint64_t>(size)) {
    throw fail("header says " + std::to_string(size) + " nodes, data has " +
               std::to_string(stream.nodes));
  }
  return resolution;
}

}  // namespace detail

std::string ObservedArea::SerializeBinary() const {
  std::ostringstream out;
  if (!impl_->tree.writeBinaryConst(out))
    throw Error(ErrorCode::kInternal, "octree: binary write failed");
  return out.str();
}

ObservedArea ObservedArea::DeserializeBinary(const std::string& bytes) {
  const double resolution = detail::ValidateOctomapBinary(bytes, "octree bytes");
  ObservedArea area(resolution);
  std::istringstream in(bytes);
  if (!area.impl_->tree.readBinary(in)) {
    throw Error(ErrorCode::kParse, "octree bytes: OctoMap rejected the tree");
  }
  return area;
}

void ObservedArea::Save(const std::string& bt_path) const {
  std::ofstream out(bt_path, std::ios::binary);
  out << SerializeBinary();
  out.close();
  if (!out) throw Error(ErrorCode::kIo, bt_path + ": cannot write octree");
}

ObservedArea ObservedArea::Load(const std::string& bt_path) {
  std::ifstream in(bt_path, std::ios::binary);
  if (!in) throw Error(ErrorCode::kIo, bt_path + ": cannot open octree file");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  try {
    return DeserializeBinary(bytes);
  } catch (const Error& e) {
    std::string message = e.what();
    if (message.rfind("octree bytes", 0) == 0) message = bt_path + message.substr(12);
    throw Error(e.code(), message);
  }
}

}  // namespace mapdelta
