#pragma once
// The shortest text in fixed notation that reads back as exactly the same double ("50",
// "-12.5", "5400000.25", "500000" rather than "5e+05"): for coordinates written into headers,
// file names and messages.
#include <charconv>
#include <string>

namespace mapdelta {

inline std::string ShortestNumber(double value) {
  char buffer[400];  // fixed notation of the largest double: 309 digits
  const auto end =
      std::to_chars(buffer, buffer + sizeof buffer, value, std::chars_format::fixed).ptr;
  return std::string(buffer, end);
}

}  // namespace mapdelta
