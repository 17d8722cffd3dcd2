#pragma once
// Internal: hash tables of 64-bit keys by open addressing (linear probing, power-of-two table,
// at most half full). Why not std::unordered_map/set (or OctoMap's KeySet): the callers insert
// many keys per call (voxel keys of rays, cells of a cloud); per insert a node-based table
// allocates and chases pointers: OctoMap's KeySet was 22 % of a server commit's CPU (sorting
// every duplicate key instead cost 13 %), the unordered_map of VoxelDownsample 0.36 ms of a
// 0.5 ms GICP cloud preparation.
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace mapdelta::detail {

// Key -> dense index 0, 1, 2, ... in first-insertion order.
class FlatKeyIndex {
 public:
  // Marks free slots: callers' keys must never equal it (their packings use <= 63 bits).
  static constexpr uint64_t kEmpty = ~uint64_t{0};

  explicit FlatKeyIndex(size_t expected = 1024) { Rehash(Capacity(expected)); }

  // The key's index, and whether it was new (then its index is the previous size()).
  std::pair<uint32_t, bool> Insert(uint64_t key) {
    if (2 * (size_ + 1) > keys_.size()) Rehash(keys_.size() * 2);
    for (size_t i = Slot(key);; i = (i + 1) & mask_) {
      if (keys_[i] == key) return {index_[i], false};
      if (keys_[i] == kEmpty) {
        keys_[i] = key;
        index_[i] = static_cast<uint32_t>(size_++);
        return {index_[i], true};
      }
    }
  }
  bool Contains(uint64_t key) const {
    for (size_t i = Slot(key);; i = (i + 1) & mask_) {
      if (keys_[i] == key) return true;
      if (keys_[i] == kEmpty) return false;
    }
  }
  size_t size() const { return size_; }
  // Calls f(key) for every key, in table order.
  template <typename F>
  void ForEach(F&& f) const {
    for (const uint64_t k : keys_) {
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
    std::vector<uint64_t> old_keys(capacity, kEmpty);
    std::vector<uint32_t> old_index(capacity, 0);
    old_keys.swap(keys_);
    old_index.swap(index_);
    mask_ = capacity - 1;
    shift_ = 64;
    for (size_t c = capacity; c > 1; c >>= 1) --shift_;
    for (size_t j = 0; j < old_keys.size(); ++j) {
      if (old_keys[j] == kEmpty) continue;
      size_t i = Slot(old_keys[j]);
      while (keys_[i] != kEmpty) i = (i + 1) & mask_;
      keys_[i] = old_keys[j];
      index_[i] = old_index[j];
    }
  }

  std::vector<uint64_t> keys_;
  std::vector<uint32_t> index_;
  size_t mask_ = 0;
  int shift_ = 64;
  size_t size_ = 0;
};

// A set of keys: the index without using it.
class FlatKeySet {
 public:
  explicit FlatKeySet(size_t expected = 1024) : index_(expected) {}
  bool Insert(uint64_t key) { return index_.Insert(key).second; }
  bool Contains(uint64_t key) const { return index_.Contains(key); }
  size_t size() const { return index_.size(); }
  template <typename F>
  void ForEach(F&& f) const {
    index_.ForEach(std::forward<F>(f));
  }

 private:
  FlatKeyIndex index_;
};

}  // namespace mapdelta::detail
