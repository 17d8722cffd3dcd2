#pragma once
// Keeps a claimed job's lease alive while the job runs: a thread renews it every third of
// its length. If a renewal finds the job leased to someone else (this worker stalled past the
// lease and another took the job over), lost() turns true and the job stops at its next
// check, writing nothing more (PostgreSQL also fences its writes on the lease).
#include <atomic>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "mapdelta/server/job_store.hpp"

namespace mapdelta::server {

class LeaseKeeper {
 public:
  LeaseKeeper(JobStore& jobs, int64_t job_id, int64_t lease_ms);
  ~LeaseKeeper();  // stops renewing (the lease then runs out unless the job is finished)
  LeaseKeeper(const LeaseKeeper&) = delete;
  LeaseKeeper& operator=(const LeaseKeeper&) = delete;

  bool lost() const { return lost_; }

 private:
  void Loop();

  JobStore& jobs_;
  const int64_t job_id_, lease_ms_;
  std::atomic<bool> lost_{false};
  bool stop_ = false;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::thread thread_;
};

}  // namespace mapdelta::server
