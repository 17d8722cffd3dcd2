#pragma once
// One exception type for programming and I/O errors across mapdelta. Expected failures
// (a registration that did not converge, a rejected keyframe) are result structs instead.
#include <stdexcept>
#include <string>
#include <string_view>

namespace mapdelta {

enum class ErrorCode {
  kInvalidArgument,  // a value the caller passed is out of its domain
  kParse,            // a file or message is malformed (the message names file/field)
  kIo,               // a file could not be opened, read or written
  kNotFound,         // a named thing does not exist
  kUnsupported,      // a format/version we do not read
  kConflict,         // state does not allow the operation
  kInternal,         // a bug
};

std::string_view ToString(ErrorCode code);

class Error : public std::runtime_error {
 public:
  Error(ErrorCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ErrorCode code() const { return code_; }

 private:
  ErrorCode code_;
};

}  // namespace mapdelta
