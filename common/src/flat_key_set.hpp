#pragma once
// Internal: a set of 64-bit keys by open addressing (linear probing, power-of-two table).
// Why not OctoMap's KeySet (std::unordered_set) or sort + unique: a keyframe's rays yield
// ~10x more voxel keys than distinct voxels; per insert the node-based set allocates and
// chases pointers (22 % of a server commit's CPU) and sorting all duplicates cost 13 %.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace mapdelta::detail {

class FlatKeySet {
 public:
  // kEmpty marks free slots: callers' keys must never equal it (packed OcTreeKeys use 48 bits).
  static constexpr uint64_t kEmpty = ~uint64_t{0};

  explicit FlatKeySet(size_t expected = 1024) { Rehash(Capacity(expected)); }

  // True if the key was not there yet.
  bool Insert(uint64_t key) {
    if (2 * (size_ + 1) > slots_.size()) Rehash(slots_.size() * 2);
    for (size_t i = Slot(key);; i = (i + 1) & mask_) {
      if (slots_[i] == key) return false;
      if (slots_[i] == kEmpty) {
        slots_[i] = key;
        ++size_;
        return true;
      }
    }
  }
  bool Contains(uint64_t key) const {
    for (size_t i = Slot(key);; i = (i + 1) & mask_) {
      if (slots_[i] == key) return true;
      if (slots_[i] == kEmpty) return false;
    }
  }
  size_t size() const { return size_; }
  // Calls f(key) for every key, in table order.
  template <typename F>
  void ForEach(F&& f) const {
    for (const uint64_t k : slots_) {
      if (k != kEmpty) f(k);
    }
  }

 private:
  static size_t Capacity(size_t expected) {
    size_t c = 16;
    while (c < 2 * expected) c *= 2;
    return c;
  }
  size_t Slot(uint64_t key) const {
    return static_cast<size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_);  // Fibonacci hashing
  }
  void Rehash(size_t capacity) {
    std::vector<uint64_t> old;
    old.swap(slots_);
    slots_.assign(capacity, kEmpty);
    mask_ = capacity - 1;
    shift_ = 64;
    for (size_t c = capacity; c > 1; c >>= 1) --shift_;
    size_ = 0;
    for (const uint64_t k : old) {
      if (k != kEmpty) Insert(k);
    }
  }

  std::vector<uint64_t> slots_;
  size_t mask_ = 0;
  int shift_ = 64;
  size_t size_ = 0;
};

}  // namespace mapdelta::detail
