#include "mapdelta/client/uploader.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"

namespace mapdelta::client {
namespace {

using Json = nlohmann::json;

// The server's error code ("keyframe_conflict", ...) from an error body, or "".
std::string ErrorCodeOf(const HttpResponse& r) {
  try {
    return Json::parse(r.body).at("error").at("code").get<std::string>();
  } catch (const std::exception&) {
    return "";
  }
}

std::string Describe(const HttpResponse& r) {
  if (r.status == 0) return "no response (" + r.error + ")";
  return "HTTP " + std::to_string(r.status) + ": " + r.body.substr(0, 300);
}

}  // namespace

std::string KeyframeMetaJson(const Keyframe& keyframe, const Eigen::Vector3d& map_origin) {
  const Eigen::Quaterniond q(keyframe.T_map_cam.linear());
  const Eigen::Vector3d t = keyframe.T_map_cam.translation() + map_origin;
  Json meta;
  meta["t_ns"] = keyframe.t_ns;
  meta["T_map_cam"] = {{"t", {t.x(), t.y(), t.z()}}, {"q", {q.w(), q.x(), q.y(), q.z()}}};
  if (keyframe.covariance) {
    Json c = Json::array();
    for (int i = 0; i < 36; ++i) c.push_back((*keyframe.covariance)(i / 6, i % 6));  // row-major
    meta["covariance"] = c;
  }
  return meta.dump();
}

Uploader::Uploader(const UploadConfig& config, const PinholeCamera& camera, UploadQueue* queue,
                   HttpTransport* transport)
    : config_(config), camera_(camera), queue_(queue), transport_(transport) {
  if (queue_ == nullptr || transport_ == nullptr) {
    throw Error(ErrorCode::kInvalidArgument, "uploader needs a queue and a transport");
  }
}

int64_t Uploader::Enqueue(const Keyframe& keyframe) {
  const auto png = EncodeDepthPng(keyframe.depth, config_.depth_scale);
  return queue_->Enqueue(KeyframeMetaJson(keyframe, map_origin_), png);
}

std::string Uploader::SessionPath() const {
  const Json id = Json::parse(*queue_->State().session_id);
  return "/v1/sessions/" + (id.is_string() ? id.get<std::string>() : id.dump());
}

void Uploader::Succeeded(double* delay_s) {
  *delay_s = config_.retry_initial_s;
  failing_since_.reset();
}

bool Uploader::Backoff(double* delay_s, const std::string& failure, const std::atomic<bool>& stop,
                       UploadReport* report) {
  const auto now = std::chrono::steady_clock::now();
  if (!failing_since_) failing_since_ = now;
  const double failing_s = std::chrono::duration<double>(now - *failing_since_).count();
  if (config_.give_up_after_s > 0 && failing_s + *delay_s > config_.give_up_after_s) {
    report->gave_up = true;
    report->fatal = "gave up after " + std::to_string(static_cast<int64_t>(std::ceil(failing_s))) +
                    " s without a successful answer from the server (upload.give_up_after_s " +
                    std::to_string(static_cast<int64_t>(config_.give_up_after_s)) +
                    "); last failure: " + failure;
    return false;
  }
  ++report->retries;
  // Sleep in small slices so a stop request is honoured promptly.
  const auto until = std::chrono::steady_clock::now() +
                     std::chrono::milliseconds(static_cast<int64_t>(*delay_s * 1000));
  while (!stop && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  *delay_s = std::min(config_.retry_max_s, *delay_s * 2.0);
  return !stop;
}

UploadReport Uploader::Run(const std::atomic<bool>& stop) {
  UploadReport report;
  failing_since_.reset();
  double delay = config_.retry_initial_s;
  while (!stop) {
    const UploadState state = queue_->State();
    if (state.session_id) report.session_id = *state.session_id;
    if (state.committed) {
      report.committed = true;
      break;
    }
    // 1. A session, created once and remembered on disk.
    if (!state.session_id) {
      const Json body = {{"vehicle_id", config_.vehicle_id},
                         {"camera",
                          {{"width", camera_.width},
                           {"height", camera_.height},
                           {"fx", camera_.fx},
                           {"fy", camera_.fy},
                           {"cx", camera_.cx},
                           {"cy", camera_.cy}}},
                         {"depth_scale", config_.depth_scale}};
      const HttpResponse r = transport_->PostJson("/v1/sessions", body.dump());
      if (r.Ok()) {
        try {
          queue_->SetSessionId(Json::parse(r.body).at("session_id").dump());
        } catch (const Json::exception&) {
          report.fatal = "create session: response has no session_id: " + r.body.substr(0, 200);
          break;
        }
        MD_LOG(kInfo, "upload: session " << *queue_->State().session_id << " created");
        Succeeded(&delay);
        continue;
      }
      if (r.Transient()) {
        MD_LOG(kWarn,
               "upload: create session failed, retrying in " << delay << " s: " << Describe(r));
        if (!Backoff(&delay, "create session: " + Describe(r), stop, &report)) break;
        continue;
      }
      report.fatal = "create session: " + Describe(r);
      break;
    }
    // 2. The oldest pending keyframe.
    if (const auto item = queue_->Front()) {
      const std::string path = SessionPath() + "/keyframes/" + std::to_string(item->seq);
      const HttpResponse r = transport_->PutKeyframe(
          path, item->meta_json, std::string(item->depth_png.begin(), item->depth_png.end()));
      if (r.Ok()) {
        queue_->MarkDone(item->seq);
        ++report.uploaded;
        Succeeded(&delay);
      } else if (r.status == 409 && ErrorCodeOf(r) == "keyframe_conflict") {
        // The server holds other content under this seq; retrying cannot help.
        MD_LOG(kError,
               "upload: keyframe " << item->seq << " conflicts with the server's: " << Describe(r));
        queue_->MarkDone(item->seq);
        ++report.conflicts;
        Succeeded(&delay);  // the server answered
      } else if (r.Transient()) {
        MD_LOG(kWarn, "upload: keyframe " << item->seq << " failed, retrying in " << delay
                                          << " s: " << Describe(r));
        if (!Backoff(&delay, "keyframe " + std::to_string(item->seq) + ": " + Describe(r), stop,
                     &report))
          break;
      } else {
        report.fatal = "keyframe " + std::to_string(item->seq) + ": " + Describe(r);
        break;
      }
      continue;
    }
    // 3. Everything sent: commit once the producer sealed the queue, else wait for more.
    if (!state.sealed) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      continue;
    }
    const HttpResponse r = transport_->PostJson(SessionPath() + "/commit", "{}");
    if (r.Ok() || (r.status == 409 && ErrorCodeOf(r) == "session_not_open")) {
      // session_not_open: our earlier commit reached the server but its answer did not reach us.
      queue_->MarkCommitted();
      MD_LOG(kInfo, "upload: session " << report.session_id << " committed");
      continue;
    }
    if (r.Transient()) {
      MD_LOG(kWarn, "upload: commit failed, retrying in " << delay << " s: " << Describe(r));
      if (!Backoff(&delay, "commit: " + Describe(r), stop, &report)) break;
      continue;
    }
    report.fatal = "commit: " + Describe(r);
    break;
  }
  if (!report.fatal.empty()) MD_LOG(kError, "upload stopped: " << report.fatal);
  return report;
}

}  // namespace mapdelta::client
