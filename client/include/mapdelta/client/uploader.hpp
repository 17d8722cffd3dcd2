#pragma once
// Stage 6: the uploader. Keyframes (fused T_map_cam, its covariance, filtered depth as 16-bit
// PNG) go into a durable UploadQueue as soon as they are final; Run() creates the session if
// the queue has none, PUTs the items in seq order (the server wants them in order), retries
// transient failures with exponential backoff, and commits once the queue is sealed and empty.
#include <atomic>
#include <chrono>
#include <optional>
#include <string>

#include "mapdelta/client/config.hpp"
#include "mapdelta/client/http_transport.hpp"
#include "mapdelta/client/upload_queue.hpp"
#include "mapdelta/common/keyframes.hpp"

namespace mapdelta::client {

// The meta JSON of docs/api.md: {"t_ns", "T_map_cam": {"t", "q": [qw,qx,qy,qz]}, "covariance"}.
// The keyframe's pose is local (prior_source.hpp); the JSON's is in map coordinates, the
// local one + map_origin, added in double.
std::string KeyframeMetaJson(const Keyframe& keyframe,
                             const Eigen::Vector3d& map_origin = Eigen::Vector3d::Zero());

struct UploadReport {
  size_t uploaded = 0;   // acknowledged keyframes (including identical retries)
  size_t conflicts = 0;  // 409: the server holds different content for that seq (not retried)
  size_t retries = 0;    // transient failures retried
  bool committed = false;
  std::string session_id;
  std::string fatal;     // non-empty: stopped on a permanent error (auth, bad request) or gave up
  bool gave_up = false;  // failed for upload.give_up_after_s without a successful answer
};

class Uploader {
 public:
  Uploader(const UploadConfig& config, const PinholeCamera& camera, UploadQueue* queue,
           HttpTransport* transport);

  // Where the keyframes' local frame sits in map coordinates (PriorSource::MapOrigin); set
  // before the first Enqueue.
  void SetMapOrigin(const Eigen::Vector3d& origin) { map_origin_ = origin; }
  // Encodes and enqueues a keyframe (durable on return). Thread-safe with Run.
  int64_t Enqueue(const Keyframe& keyframe);

  // Works until the session is committed, a permanent error occurs, or stop becomes true.
  // While the queue is not sealed and empty it waits for more items.
  UploadReport Run(const std::atomic<bool>& stop);

 private:
  // After a transient failure: false to stop (stop requested, or failing for longer than
  // give_up_after_s, which sets report->fatal), else sleeps and doubles the delay.
  bool Backoff(double* delay_s, const std::string& failure, const std::atomic<bool>& stop,
               UploadReport* report);
  void Succeeded(double* delay_s);
  std::string SessionPath() const;

  UploadConfig config_;
  PinholeCamera camera_;
  UploadQueue* queue_;
  HttpTransport* transport_;
  Eigen::Vector3d map_origin_ = Eigen::Vector3d::Zero();
  std::optional<std::chrono::steady_clock::time_point>
      failing_since_;  // of the current failure streak
};

}  // namespace mapdelta::client
