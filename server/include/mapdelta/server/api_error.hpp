#pragma once
// The one error table of the API: code -> HTTP status -> default message. The service throws
// ApiError; the HTTP adapter turns it into {"error": {"code", "message"}} with the status.
#include <stdexcept>
#include <string>
#include <string_view>

namespace mapdelta::server {

enum class ApiCode {
  kUnauthenticated,    // 401 missing, malformed, unknown or revoked token
  kForbidden,          // 403 valid token, role not allowed
  kNotFound,           // 404 unknown session, tile, job, version or route
  kInvalidJson,        // 400 body is not JSON
  kInvalidArgument,    // 400 a field is missing, of the wrong type or out of range
  kInvalidImage,       // 400 depth is not a decodable 16-bit PNG
  kImageSizeMismatch,  // 422 depth size differs from the session camera
  kInvalidPose,        // 422 NaN/inf pose or non-unit quaternion, bad covariance
  kPayloadTooLarge,    // 413
  kUnsupportedMedia,   // 415 wrong Content-Type
  kKeyframeConflict,   // 409 same seq uploaded with different content
  kSeqOutOfOrder,      // 409 seq is not the next one
  kTimeNotIncreasing,  // 409 t_ns not after the previous keyframe's
  kSessionNotOpen,     // 409 session already committed / committing
  kJobNotCancellable,  // 409 job already finished
  kNoPrior,            // 409 no prior map imported yet
  kClusterState,       // 409 a change cluster's state does not allow the decision
  kLimitExceeded,      // 422 too many keyframes in a session
  kShuttingDown,       // 503
  kInternal,           // 500
};

struct ApiErrorInfo {
  ApiCode code;
  std::string_view name;  // snake_case, stable, documented in openapi.yaml
  int http_status;
};

const ApiErrorInfo& Info(ApiCode code);

class ApiError : public std::runtime_error {
 public:
  ApiError(ApiCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ApiCode code() const { return code_; }

 private:
  ApiCode code_;
};

}  // namespace mapdelta::server
