// Lease owner ids of job workers (job_store.hpp).
#include <unistd.h>

#include <cstdio>
#include <random>
#include <string>

#include "mapdelta/server/job_store.hpp"

namespace mapdelta::server {

std::string NewWorkerId() {
  char host[256] = {0};
  if (::gethostname(host, sizeof(host) - 1) != 0) std::snprintf(host, sizeof(host), "unknown");
  // The random part tells apart two processes with the same pid (containers, restarts).
  std::random_device rd;
  char tail[16];
  std::snprintf(tail, sizeof(tail), "%08x", rd());
  return std::string(host) + ":" + std::to_string(::getpid()) + ":" + tail;
}

}  // namespace mapdelta::server
