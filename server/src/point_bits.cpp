#include "point_bits.hpp"

#include <bit>
#include <string>

#include "mapdelta/common/error.hpp"

namespace mapdelta::server {

PointBits PointBits::FromWords(size_t size, std::vector<uint64_t> words) {
  if (words.size() != (size + 63) / 64) {
    throw Error(ErrorCode::kParse, "point bits: " + std::to_string(words.size()) + " words for " +
                                       std::to_string(size) + " bits");
  }
  if (size % 64 != 0 && (words.back() >> (size % 64)) != 0)
    throw Error(ErrorCode::kParse, "point bits: a bit past the end is set");
  PointBits out(0);
  out.size_ = size;
  out.words_ = std::move(words);
  return out;
}

size_t PointBits::Count() const {
  size_t n = 0;
  for (uint64_t w : words_) n += static_cast<size_t>(std::popcount(w));
  return n;
}

void PointBits::Or(const PointBits& other) {
  if (other.size_ != size_) {
    throw Error(ErrorCode::kInternal, "point bits: OR of " + std::to_string(size_) + " and " +
                                          std::to_string(other.size_) + " bits");
  }
  for (size_t i = 0; i < words_.size(); ++i) words_[i] |= other.words_[i];
}

}  // namespace mapdelta::server
