#include "pg_pool.hpp"

namespace mapdelta::server::pg {

Pool::Pool(std::string conninfo, int max_connections)
    : conninfo_(std::move(conninfo)), max_connections_(max_connections < 1 ? 1 : max_connections) {
  idle_.push_back(std::make_unique<Connection>(conninfo_));
  open_ = 1;
}

Pool::Lease Pool::Acquire() {
  std::unique_lock lock(mutex_);
  released_.wait(lock, [&] { return !idle_.empty() || open_ < max_connections_; });
  if (!idle_.empty()) {
    std::unique_ptr<Connection> conn = std::move(idle_.back());
    idle_.pop_back();
    return Lease(*this, std::move(conn));
  }
  ++open_;
  lock.unlock();
  try {
    return Lease(*this, std::make_unique<Connection>(conninfo_));
  } catch (...) {
    std::lock_guard relock(mutex_);
    --open_;
    released_.notify_one();
    throw;
  }
}

void Pool::Release(std::unique_ptr<Connection> conn) {
  std::lock_guard lock(mutex_);
  if (conn && conn->reusable()) {
    idle_.push_back(std::move(conn));
  } else {
    --open_;
  }
  released_.notify_one();
}

}  // namespace mapdelta::server::pg
