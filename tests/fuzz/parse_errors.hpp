#pragma once
// What a library reader of outside files (clouds, sensor.yaml, CSV, config, .bt) may throw for
// bad input in a fuzz target; anything else escapes the target and is a finding.
#include <functional>

#include "mapdelta/common/error.hpp"

namespace mapdelta::fuzz {

// A named parse or argument error is the expected answer; an I/O error here would mean the
// reader misreported bad content.
inline void ExpectParseErrorOnly(const std::function<void()>& decode) {
  try {
    decode();
  } catch (const Error& e) {
    if (e.code() != ErrorCode::kParse && e.code() != ErrorCode::kInvalidArgument) throw;
  }
}

}  // namespace mapdelta::fuzz
