#pragma once
// What a server decoder may throw for bad input: exactly the exceptions the HTTP wrapper
// (server/src/http_handlers.cpp, Wrap) answers with a 4xx. Anything else (a 500, a crash, a
// sanitizer report) escapes the fuzz target and is a finding.
#include <exception>
#include <functional>

#include "mapdelta/common/error.hpp"
#include "mapdelta/server/map_service.hpp"

namespace mapdelta::fuzz {

inline void ExpectClientErrorOnly(const std::function<void()>& decode) {
  try {
    decode();
  } catch (const server::ApiError& e) {
    if (server::Info(e.code()).http_status >= 500) throw;
  } catch (const server::Json::exception&) {
  } catch (const Error& e) {
    const ErrorCode c = e.code();
    if (c != ErrorCode::kInvalidArgument && c != ErrorCode::kParse && c != ErrorCode::kNotFound)
      throw;
  }
}

}  // namespace mapdelta::fuzz
