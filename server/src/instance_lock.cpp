#include "instance_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"

namespace mapdelta::server {
namespace {

std::string ReadHolder(int fd) {
  char buf[64] = {0};
  const ssize_t n = ::pread(fd, buf, sizeof(buf) - 1, 0);
  std::string text = n > 0 ? std::string(buf, static_cast<size_t>(n)) : "";
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  return text.empty() ? "a process that has not written its pid yet" : text;
}

}  // namespace

InstanceLock::InstanceLock(InstanceLock&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }

InstanceLock::~InstanceLock() {
  if (fd_ >= 0) ::close(fd_);  // closing the only descriptor releases the flock
}

std::string InstanceLock::PathFor(const std::string& database) { return database + ".serve-lock"; }

std::optional<InstanceLock> InstanceLock::TryAcquire(const std::string& lock_path,
                                                     std::string* holder) {
  // O_CLOEXEC: a child process must not inherit (and so keep) the lock.
  const int fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) {
    throw Error(ErrorCode::kIo, lock_path + ": cannot open the lock file: " + std::strerror(errno));
  }
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    if (err == EWOULDBLOCK) {
      if (holder) *holder = ReadHolder(fd);
      ::close(fd);
      return std::nullopt;
    }
    ::close(fd);
    throw Error(ErrorCode::kIo, lock_path + ": cannot lock: " + std::strerror(err));
  }
  // The pid only names the holder in the next process's error message; the flock is the lock,
  // so a failed write costs that name, not the start.
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, pid.data(), pid.size(), 0) < 0) {
    MD_LOG(kWarn, lock_path << ": cannot write this process's pid: " << std::strerror(errno));
  }
  return InstanceLock(fd);
}

}  // namespace mapdelta::server
