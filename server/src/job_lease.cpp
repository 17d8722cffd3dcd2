#include "job_lease.hpp"

#include <chrono>

#include "mapdelta/common/log.hpp"
#include "mapdelta/server/map_service.hpp"

namespace mapdelta::server {

LeaseKeeper::LeaseKeeper(JobStore& jobs, int64_t job_id, int64_t lease_ms)
    : jobs_(jobs), job_id_(job_id), lease_ms_(lease_ms), thread_([this] { Loop(); }) {}

LeaseKeeper::~LeaseKeeper() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void LeaseKeeper::Loop() {
  const auto period = std::chrono::milliseconds(lease_ms_ / 3);
  std::unique_lock lock(mutex_);
  while (!wake_.wait_for(lock, period, [&] { return stop_; })) {
    try {
      if (!jobs_.RenewLease(job_id_, NowMs(), lease_ms_)) {
        MD_LOG(kWarn, "job " << job_id_ << ": lease lost (another worker took it over); stopping");
        lost_ = true;
        return;
      }
    } catch (const std::exception& e) {
      // The database may be back before the lease runs out: keep trying.
      MD_LOG(kWarn, "job " << job_id_ << ": lease renewal failed: " << e.what());
    }
  }
}

}  // namespace mapdelta::server
