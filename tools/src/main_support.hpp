#pragma once
// The one place the tools turn exceptions into "<tool>: error: <message>" and an exit code.
#include <exception>
#include <functional>
#include <iostream>
#include <string>
#include <vector>

#include "mapdelta/common/error.hpp"

namespace mapdelta::tools {

inline int RunMain(const char* tool, const std::function<int()>& body) {
  try {
    return body();
  } catch (const Error& e) {
    std::cerr << tool << ": error: " << e.what() << "\n";
    return e.code() == ErrorCode::kInvalidArgument ? 2 : 1;
  } catch (const std::exception& e) {
    std::cerr << tool << ": error: " << e.what() << "\n";
    return 1;
  }
}

inline bool WantsHelp(const std::vector<std::string>& args) {
  for (const auto& a : args) {
    if (a == "--help" || a == "-h") return true;
  }
  return false;
}

}  // namespace mapdelta::tools
