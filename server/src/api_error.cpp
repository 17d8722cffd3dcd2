#include "mapdelta/server/api_error.hpp"

#include <array>

namespace mapdelta::server {

namespace {
constexpr std::array kTable = {
    ApiErrorInfo{ApiCode::kUnauthenticated, "unauthenticated", 401},
    ApiErrorInfo{ApiCode::kForbidden, "forbidden", 403},
    ApiErrorInfo{ApiCode::kNotFound, "not_found", 404},
    ApiErrorInfo{ApiCode::kInvalidJson, "invalid_json", 400},
    ApiErrorInfo{ApiCode::kInvalidArgument, "invalid_argument", 400},
    ApiErrorInfo{ApiCode::kInvalidImage, "invalid_image", 400},
    ApiErrorInfo{ApiCode::kImageSizeMismatch, "image_size_mismatch", 422},
    ApiErrorInfo{ApiCode::kInvalidPose, "invalid_pose", 422},
    ApiErrorInfo{ApiCode::kPayloadTooLarge, "payload_too_large", 413},
    ApiErrorInfo{ApiCode::kUnsupportedMedia, "unsupported_media_type", 415},
    ApiErrorInfo{ApiCode::kKeyframeConflict, "keyframe_conflict", 409},
    ApiErrorInfo{ApiCode::kSeqOutOfOrder, "seq_out_of_order", 409},
    ApiErrorInfo{ApiCode::kTimeNotIncreasing, "time_not_increasing", 409},
    ApiErrorInfo{ApiCode::kSessionNotOpen, "session_not_open", 409},
    ApiErrorInfo{ApiCode::kJobNotCancellable, "job_not_cancellable", 409},
    ApiErrorInfo{ApiCode::kNoPrior, "no_prior", 409},
    ApiErrorInfo{ApiCode::kClusterState, "cluster_state_conflict", 409},
    ApiErrorInfo{ApiCode::kLimitExceeded, "limit_exceeded", 422},
    ApiErrorInfo{ApiCode::kShuttingDown, "shutting_down", 503},
    ApiErrorInfo{ApiCode::kInternal, "internal", 500},
};
}  // namespace

const ApiErrorInfo& Info(ApiCode code) {
  for (const auto& info : kTable) {
    if (info.code == code) return info;
  }
  return kTable.back();
}

}  // namespace mapdelta::server
