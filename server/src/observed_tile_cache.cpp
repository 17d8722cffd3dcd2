#include "observed_tile_cache.hpp"

#include <exception>

namespace mapdelta::server {

struct ObservedTileCache::Build {
  std::condition_variable done_cv;
  bool done = false;
  std::shared_ptr<const std::string> bytes;
  std::exception_ptr error;
};

std::shared_ptr<const std::string> ObservedTileCache::Get(
    const std::string& key, const std::function<std::string()>& build) {
  if (max_bytes_ == 0) {
    {
      std::lock_guard lock(mutex_);
      stats_.misses += 1;
    }
    return std::make_shared<const std::string>(build());
  }
  std::shared_ptr<Build> pending;
  {
    std::unique_lock lock(mutex_);
    if (auto it = entries_.find(key); it != entries_.end()) {
      lru_.splice(lru_.begin(), lru_, it->second.lru);
      stats_.hits += 1;
      return it->second.bytes;
    }
    if (auto it = building_.find(key); it != building_.end()) {
      // Another request builds these bytes: wait for it instead of merging the octrees twice.
      pending = it->second;
      stats_.shared += 1;
      pending->done_cv.wait(lock, [&] { return pending->done; });
      if (pending->error) std::rethrow_exception(pending->error);
      return pending->bytes;
    }
    pending = std::make_shared<Build>();
    building_.emplace(key, pending);
    stats_.misses += 1;
  }
  // Built outside the lock: other tiles are served (and built) meanwhile.
  std::shared_ptr<const std::string> bytes;
  std::exception_ptr error;
  try {
    bytes = std::make_shared<const std::string>(build());
  } catch (...) {
    error = std::current_exception();
  }
  {
    std::lock_guard lock(mutex_);
    building_.erase(key);
    if (bytes) InsertLocked(key, bytes);
    pending->bytes = bytes;
    pending->error = error;
    pending->done = true;
  }
  pending->done_cv.notify_all();
  if (error) std::rethrow_exception(error);
  return bytes;
}

void ObservedTileCache::InsertLocked(const std::string& key,
                                     std::shared_ptr<const std::string> bytes) {
  const int64_t size = static_cast<int64_t>(bytes->size() + key.size());
  if (size > max_bytes_) {
    stats_.too_large += 1;
    return;
  }
  while (bytes_ + size > max_bytes_ && !lru_.empty()) {
    auto victim = entries_.find(lru_.back());
    bytes_ -= static_cast<int64_t>(victim->second.bytes->size() + victim->first.size());
    entries_.erase(victim);
    lru_.pop_back();
    stats_.evictions += 1;
  }
  lru_.push_front(key);
  entries_.emplace(key, Entry{std::move(bytes), lru_.begin()});
  bytes_ += size;
}

ObservedCacheStats ObservedTileCache::Stats() const {
  std::lock_guard lock(mutex_);
  ObservedCacheStats s = stats_;
  s.bytes = bytes_;
  s.entries = static_cast<int64_t>(entries_.size());
  s.max_bytes = max_bytes_;
  return s;
}

}  // namespace mapdelta::server
