#pragma once
// The served observed octrees (GET /v1/observed/tiles/{t}.bt), least recently used first out,
// bounded by their bytes. Building one merges every session octree of the tile (seconds with
// dozens of sessions), so a reader's repeated fetch must not redo it. Keys name the stored tile
// state the bytes were built from (ObservedTileKey): a commit, by any process on the database,
// changes the state and so the key, and the old entry is never asked for again (it ages out).
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "mapdelta/server/metrics.hpp"

namespace mapdelta::server {

class ObservedTileCache {
 public:
  // max_bytes 0: off (every Get builds; concurrent builds of one key are not shared either).
  explicit ObservedTileCache(int64_t max_bytes) : max_bytes_(max_bytes) {}

  // The bytes for key: the cached ones, or build()'s. Concurrent calls for a key that is being
  // built wait for that build and share its result (or its exception: nothing is cached then,
  // and the next call builds again). An entry larger than the bound is served, not kept.
  std::shared_ptr<const std::string> Get(const std::string& key,
                                         const std::function<std::string()>& build);

  ObservedCacheStats Stats() const;

 private:
  struct Build;  // one build in progress, shared by its waiters
  struct Entry {
    std::shared_ptr<const std::string> bytes;
    std::list<std::string>::iterator lru;  // position in lru_
  };
  void InsertLocked(const std::string& key, std::shared_ptr<const std::string> bytes);

  const int64_t max_bytes_;
  mutable std::mutex mutex_;
  std::map<std::string, Entry> entries_;
  std::list<std::string> lru_;  // most recently used first
  std::map<std::string, std::shared_ptr<Build>> building_;
  int64_t bytes_ = 0;
  ObservedCacheStats stats_;
};

}  // namespace mapdelta::server
