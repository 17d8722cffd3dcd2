#pragma once
// A fixed-size set of bits over a prior tile's points (bit i = the tile's i-th point), the
// per-session coverage of a tile (coverage.hpp); stored through blob_codec's EncodePointBits.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace mapdelta::server {

class PointBits {
 public:
  explicit PointBits(size_t size = 0) : size_(size), words_((size + 63) / 64, 0) {}
  // From stored words; throws Error(kParse) if their number does not match size or a bit past
  // size is set (a damaged or foreign blob).
  static PointBits FromWords(size_t size, std::vector<uint64_t> words);

  size_t size() const { return size_; }
  void Set(size_t i) { words_[i / 64] |= uint64_t{1} << (i % 64); }
  bool Test(size_t i) const { return (words_[i / 64] >> (i % 64)) & 1; }
  size_t Count() const;
  // This | other; throws Error(kInternal) if the sizes differ (bits of different prior rows).
  void Or(const PointBits& other);
  const std::vector<uint64_t>& words() const { return words_; }

 private:
  size_t size_;
  std::vector<uint64_t> words_;
};

}  // namespace mapdelta::server
