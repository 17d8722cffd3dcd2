#pragma once
// One serving process per SQLite database: an exclusive flock(2) on a lock file beside it,
// held for the life of the process. The kernel drops it when the process dies in any way
// (SIGKILL included), so a crashed server never leaves a stale lock behind.
#include <optional>
#include <string>

namespace mapdelta::server {

class InstanceLock {
 public:
  InstanceLock(InstanceLock&& other) noexcept;
  InstanceLock& operator=(InstanceLock&&) = delete;
  InstanceLock(const InstanceLock&) = delete;
  InstanceLock& operator=(const InstanceLock&) = delete;
  ~InstanceLock();

  // The lock file of a database: "<database>.serve-lock".
  static std::string PathFor(const std::string& database);
  // Takes the lock at `lock_path`, creating the file if needed, and writes this process's pid
  // into it. nullopt if another process holds it; `*holder` then says who (its pid, as written
  // into the file). Throws Error(kIo) if the file cannot be created or locked for another
  // reason.
  static std::optional<InstanceLock> TryAcquire(const std::string& lock_path, std::string* holder);

 private:
  explicit InstanceLock(int fd) : fd_(fd) {}
  int fd_ = -1;
};

}  // namespace mapdelta::server
