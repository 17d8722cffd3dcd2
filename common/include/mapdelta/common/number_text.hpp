#pragma once
// The shortest text that reads back as exactly the same double ("50", "-12.5", "5400000.25"),
// as std::to_chars gives it: for coordinates written into headers, file names and messages.
#include <charconv>
#include <string>

namespace mapdelta {

inline std::string ShortestNumber(double value) {
  char buffer[64];  // to_chars needs at most 24 characters for a double
  const auto end = std::to_chars(buffer, buffer + sizeof buffer, value).ptr;
  return std::string(buffer, end);
}

}  // namespace mapdelta
