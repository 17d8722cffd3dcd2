// ObservedArea persistence: OctoMap's .bt format (free / occupied per voxel) and its .ot format
// (every node's log-odds), each validated in full before OctoMap parses it (OctoMap's readers
// trust the stream: a truncated or forged one can make them allocate nodes from uninitialised
// bytes).
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

#include "mapdelta/common/error.hpp"
#include "observed_area_impl.hpp"

namespace mapdelta {
namespace detail {
namespace {

constexpr std::string_view kBinaryHeader = "# Octomap OcTree binary file";
constexpr std::string_view kFullHeader = "# Octomap OcTree file";
constexpr int kTreeDepth = 16;

struct BitStream {
  std::string_view data;
  size_t pos = 0;
  uint64_t nodes = 1;  // the root
};

// Mirrors OcTreeBaseImpl::readNodesRecurs with OcTreeNode's data: per node its log-odds (a
// float) and one byte with a bit per allocated child, children following recursively.
bool WalkFullNode(BitStream* s, int depth, std::string* problem) {
  if (s->pos + sizeof(float) + 1 > s->data.size()) {
    *problem = "node data ends early";
    return false;
  }
  float log_odds = 0;
  std::memcpy(&log_odds, s->data.data() + s->pos, sizeof log_odds);
  if (!std::isfinite(log_odds)) {
    *problem = "a node's log-odds is not finite";
    return false;
  }
  const auto children = static_cast<unsigned char>(s->data[s->pos + sizeof(float)]);
  s->pos += sizeof(float) + 1;
  for (int child = 0; child < 8; ++child) {
    if (!(children & (1u << child))) continue;
    ++s->nodes;
    if (depth + 1 > kTreeDepth) {  // leaves are at depth 16
      *problem = "node below the deepest level";
      return false;
    }
    if (!WalkFullNode(s, depth + 1, problem)) return false;
  }
  return true;
}

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

OctomapStream ValidateOctomapStream(std::string_view bytes, const std::string& what) {
  const auto first_line = bytes.substr(0, bytes.find('\n'));
  const bool full = first_line == kFullHeader;
  const auto fail = [&](const std::string& problem) {
    return Error(ErrorCode::kParse, what + ": not a valid OctoMap " +
                                        (full ? "(.ot)" : "binary (.bt)") + " tree: " + problem);
  };
  if (!full && bytes.substr(0, kBinaryHeader.size()) != kBinaryHeader) {
    throw fail("first line must be '" + std::string(kBinaryHeader) + "' or '" +
               std::string(kFullHeader) + "'");
  }
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
  const OctomapStream result{resolution, pos, full, size == 0};
  if (size == 0) {
    if (!stream.data.empty()) throw fail("size 0 but node data follows");
    return result;
  }
  std::string problem;
  if (!(full ? WalkFullNode(&stream, 0, &problem) : WalkNode(&stream, 0, &problem)))
    throw fail(problem);
  if (stream.pos != stream.data.size()) throw fail("trailing bytes after the node data");
  if (stream.nodes != static_cast<uint64_t>(size)) {
    throw fail("header says " + std::to_string(size) + " nodes, data has " +
               std::to_string(stream.nodes));
  }
  return result;
}

}  // namespace detail

std::string ObservedArea::SerializeBinary() const {
  std::ostringstream out;
  if (!impl_->tree.writeBinaryConst(out))
    throw Error(ErrorCode::kInternal, "octree: binary write failed");
  return out.str();
}

std::string ObservedArea::SerializeEvidence() const {
  std::ostringstream out;
  if (!impl_->tree.write(out)) throw Error(ErrorCode::kInternal, "octree: write failed");
  return out.str();
}

ObservedArea ObservedArea::DeserializeBinary(const std::string& bytes) {
  const detail::OctomapStream stream = detail::ValidateOctomapStream(bytes, "octree bytes");
  ObservedArea area(stream.resolution_m);
  std::istringstream in(bytes);
  if (stream.full) {
    // The header is checked above; OcTree::readData reads the nodes after it.
    in.seekg(static_cast<std::streamoff>(stream.data_offset));
    if (!stream.empty && !area.impl_->tree.readData(in)) {
      throw Error(ErrorCode::kParse, "octree bytes: OctoMap rejected the tree");
    }
  } else if (!area.impl_->tree.readBinary(in)) {
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
