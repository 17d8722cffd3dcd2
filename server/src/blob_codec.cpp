#include "blob_codec.hpp"

#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <string_view>

#include "mapdelta/common/error.hpp"

namespace mapdelta::server {
namespace {

constexpr char kMagic[4] = {'M', 'D', 'B', '1'};
constexpr uint16_t kFormatVersion = 1;
constexpr uint64_t kMaxDeflateRatio = 1032;
enum Kind : uint8_t {
  kPoints = 1,
  kAggregate = 2,
  kChanges = 3,
  kObserved = 4,
  kVoxelKeys = 5,
  kPointBits = 6,
  kAggregateWithKeyframes = 7  // kAggregate plus each voxel's keyframe support (issue 21)
};

class Writer {
 public:
  template <typename T>
  void Put(const T& v) {
    const auto* p = reinterpret_cast<const uint8_t*>(&v);
    buf_.insert(buf_.end(), p, p + sizeof(T));
  }
  void PutIds(const std::vector<int64_t>& ids) {
    Put(static_cast<uint32_t>(ids.size()));
    for (int64_t id : ids) Put(id);
  }
  Bytes& buf() { return buf_; }

 private:
  Bytes buf_;
};

class Reader {
 public:
  explicit Reader(const Bytes& b) : b_(b) {}
  template <typename T>
  T Get() {
    if (pos_ + sizeof(T) > b_.size()) throw Error(ErrorCode::kParse, "blob truncated");
    T v;
    std::memcpy(&v, b_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::vector<int64_t> GetIds() {
    const auto n = Get<uint32_t>();
    if (n > (b_.size() - pos_) / sizeof(int64_t))
      throw Error(ErrorCode::kParse, "blob id list too long");
    std::vector<int64_t> ids(n);
    for (auto& id : ids) id = Get<int64_t>();
    return ids;
  }
  bool done() const { return pos_ == b_.size(); }

 private:
  const Bytes& b_;
  size_t pos_ = 0;
};

Bytes Seal(Kind kind, const Bytes& raw) {
  uLongf bound = compressBound(raw.size());
  Bytes z(bound);
  if (compress2(z.data(), &bound, raw.data(), raw.size(), Z_BEST_SPEED) != Z_OK) {
    throw Error(ErrorCode::kInternal, "zlib compression failed");
  }
  z.resize(bound);
  Writer w;
  w.buf().reserve(32 + z.size());  // also keeps GCC 12 from a false -Wstringop-overflow
  for (char c : kMagic) w.Put(c);
  w.Put(static_cast<uint8_t>(kind));
  w.Put(kFormatVersion);
  w.Put(static_cast<uint64_t>(raw.size()));
  w.Put(static_cast<uint32_t>(crc32(0, raw.data(), raw.size())));
  w.buf().insert(w.buf().end(), z.begin(), z.end());
  return std::move(w.buf());
}

Bytes Open(Kind kind, const Bytes& blob) {
  constexpr size_t kHeader = 4 + 1 + 2 + 8 + 4;
  if (blob.size() < kHeader || std::memcmp(blob.data(), kMagic, 4) != 0) {
    throw Error(ErrorCode::kParse, "stored blob has no mapdelta header");
  }
  Reader r(blob);
  for (int i = 0; i < 4; ++i) r.Get<char>();
  if (r.Get<uint8_t>() != kind) throw Error(ErrorCode::kParse, "stored blob has the wrong kind");
  const auto version = r.Get<uint16_t>();
  if (version != kFormatVersion) {
    throw Error(ErrorCode::kUnsupported,
                "stored blob format version " + std::to_string(version) + " is not supported");
  }
  const auto raw_size = r.Get<uint64_t>();
  const auto crc = r.Get<uint32_t>();
  if (raw_size > (uint64_t{1} << 32)) throw Error(ErrorCode::kParse, "stored blob too large");
  // Deflate expands at most 1032:1, so a larger claim is damage; checked before allocating it.
  const uint64_t compressed = blob.size() - kHeader;
  if (raw_size > kMaxDeflateRatio * compressed + 64) {
    throw Error(ErrorCode::kParse, "stored blob claims " + std::to_string(raw_size) +
                                       " bytes from " + std::to_string(compressed) + " compressed");
  }
  Bytes raw(raw_size);
  uLongf out = raw_size;
  if (uncompress(raw.data(), &out, blob.data() + kHeader, blob.size() - kHeader) != Z_OK ||
      out != raw_size) {
    throw Error(ErrorCode::kParse, "stored blob does not decompress");
  }
  if (crc32(0, raw.data(), raw.size()) != crc)
    throw Error(ErrorCode::kParse, "stored blob checksum mismatch");
  return raw;
}

}  // namespace

Bytes EncodePoints(const PointCloud& cloud) {
  Writer w;
  w.Put(static_cast<uint64_t>(cloud.size()));
  for (const Point& p : cloud) {
    w.Put(p.x());
    w.Put(p.y());
    w.Put(p.z());
  }
  return Seal(kPoints, w.buf());
}

PointCloud DecodePoints(const Bytes& blob) {
  if (blob.empty()) return {};  // an empty tile row (tile emptied by an import)
  const Bytes raw = Open(kPoints, blob);
  Reader r(raw);
  const auto n = r.Get<uint64_t>();
  if (n != (raw.size() - 8) / 12) throw Error(ErrorCode::kParse, "points blob size mismatch");
  PointCloud cloud(n);
  for (Point& p : cloud) {
    const float x = r.Get<float>(), y = r.Get<float>(), z = r.Get<float>();
    p = Point(x, y, z);
  }
  return cloud;
}

Bytes EncodeAggregate(const TileAggregate& aggregate) {
  Writer w;
  w.Put(static_cast<uint64_t>(aggregate.size()));
  for (const auto& [key, v] : aggregate) {
    for (int32_t k : key) w.Put(k);
    w.Put(v.centroid.x());
    w.Put(v.centroid.y());
    w.Put(v.centroid.z());
    w.Put(v.point_count);
    w.Put(v.keyframes);
    w.PutIds(v.sessions);
  }
  return Seal(kAggregateWithKeyframes, w.buf());
}

TileAggregate DecodeAggregate(const Bytes& blob) {
  // Aggregates stored before the keyframe support (kind 2) read with keyframes 0: unknown.
  constexpr size_t kKindOffset = 4;
  const bool with_keyframes =
      blob.size() > kKindOffset && blob[kKindOffset] == kAggregateWithKeyframes;
  const Bytes raw = Open(with_keyframes ? kAggregateWithKeyframes : kAggregate, blob);
  Reader r(raw);
  const auto n = r.Get<uint64_t>();
  TileAggregate out;
  for (uint64_t i = 0; i < n; ++i) {
    VoxelKey key{r.Get<int32_t>(), r.Get<int32_t>(), r.Get<int32_t>()};
    AggregateVoxel v;
    const float x = r.Get<float>(), y = r.Get<float>(), z = r.Get<float>();
    v.centroid = Point(x, y, z);
    v.point_count = r.Get<uint32_t>();
    if (with_keyframes) v.keyframes = r.Get<uint32_t>();
    v.sessions = r.GetIds();
    out.emplace(key, std::move(v));
  }
  if (!r.done()) throw Error(ErrorCode::kParse, "aggregate blob has trailing bytes");
  return out;
}

Bytes EncodeChanges(const std::vector<ChangePoint>& changes) {
  Writer w;
  w.Put(static_cast<uint64_t>(changes.size()));
  for (const ChangePoint& c : changes) {
    w.Put(c.position.x());
    w.Put(c.position.y());
    w.Put(c.position.z());
    w.Put(static_cast<uint8_t>(c.kind));
    w.Put(c.confidence);
    w.PutIds(c.observed_by);
    w.PutIds(c.supported_by);
  }
  return Seal(kChanges, w.buf());
}

std::vector<ChangePoint> DecodeChanges(const Bytes& blob) {
  const Bytes raw = Open(kChanges, blob);
  Reader r(raw);
  const auto n = r.Get<uint64_t>();
  std::vector<ChangePoint> out;
  for (uint64_t i = 0; i < n; ++i) {
    ChangePoint c;
    const float x = r.Get<float>(), y = r.Get<float>(), z = r.Get<float>();
    c.position = Point(x, y, z);
    const auto kind = r.Get<uint8_t>();
    if (kind > 1) throw Error(ErrorCode::kParse, "changes blob has an unknown kind");
    c.kind = static_cast<ChangeKind>(kind);
    c.confidence = r.Get<float>();
    c.observed_by = r.GetIds();
    c.supported_by = r.GetIds();
    out.push_back(std::move(c));
  }
  if (!r.done()) throw Error(ErrorCode::kParse, "changes blob has trailing bytes");
  return out;
}

Bytes EncodeVoxelKeys(const std::vector<VoxelKey>& keys) {
  Writer w;
  w.Put(static_cast<uint64_t>(keys.size()));
  for (const VoxelKey& k : keys) {
    for (int32_t v : k) w.Put(v);
  }
  return Seal(kVoxelKeys, w.buf());
}

std::vector<VoxelKey> DecodeVoxelKeys(const Bytes& blob) {
  const Bytes raw = Open(kVoxelKeys, blob);
  Reader r(raw);
  const auto n = r.Get<uint64_t>();
  if (n > raw.size() / 12) throw Error(ErrorCode::kParse, "voxel keys blob is truncated");
  std::vector<VoxelKey> out(n);
  for (VoxelKey& k : out) {
    for (int32_t& v : k) v = r.Get<int32_t>();
  }
  if (!r.done()) throw Error(ErrorCode::kParse, "voxel keys blob has trailing bytes");
  return out;
}

Bytes EncodeObserved(const std::string& octree_binary) {
  return Seal(kObserved, Bytes(octree_binary.begin(), octree_binary.end()));
}

std::string DecodeObserved(const Bytes& blob) {
  // OctoMap's writeBinary starts every stream with this line (octomap/AbstractOcTree.cpp).
  static constexpr std::string_view kLegacyOctomapHeader = "# Octomap OcTree binary file";
  if (blob.size() >= kLegacyOctomapHeader.size() &&
      std::equal(kLegacyOctomapHeader.begin(), kLegacyOctomapHeader.end(), blob.begin())) {
    return std::string(blob.begin(), blob.end());
  }
  const Bytes raw = Open(kObserved, blob);
  return std::string(raw.begin(), raw.end());
}

}  // namespace mapdelta::server

namespace mapdelta::server {

Bytes EncodePointBits(const PointBits& bits) {
  Writer w;
  w.Put(static_cast<uint64_t>(bits.size()));
  for (uint64_t word : bits.words()) w.Put(word);
  return Seal(kPointBits, w.buf());
}

PointBits DecodePointBits(const Bytes& blob) {
  const Bytes raw = Open(kPointBits, blob);
  Reader r(raw);
  const auto n = r.Get<uint64_t>();
  if (n > uint64_t{8} * raw.size()) throw Error(ErrorCode::kParse, "point bits blob is truncated");
  std::vector<uint64_t> words((n + 63) / 64);
  for (uint64_t& word : words) word = r.Get<uint64_t>();
  if (!r.done()) throw Error(ErrorCode::kParse, "point bits blob has trailing bytes");
  return PointBits::FromWords(static_cast<size_t>(n), std::move(words));
}

}  // namespace mapdelta::server
