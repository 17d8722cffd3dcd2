#pragma once
// The one logger every mapdelta library writes through. Libraries never print to stdout;
// log lines go to stderr (or a sink the executable installs), one line each, with a level.
#include <functional>
#include <sstream>
#include <string>
#include <string_view>

namespace mapdelta::log {

enum class Level { kDebug = 0, kInfo = 1, kWarn = 2, kError = 3, kOff = 4 };

void SetLevel(Level level);
Level GetLevel();
bool ParseLevel(std::string_view text, Level* level);
// Replaces the sink (default: timestamped lines on stderr). Thread-safe.
void SetSink(std::function<void(Level, const std::string&)> sink);
void Write(Level level, const std::string& message);

}  // namespace mapdelta::log

// Usage: MD_LOG(kInfo, "loaded " << n << " points from " << path);
#define MD_LOG(level, expr)                                                        \
  do {                                                                             \
    if (::mapdelta::log::Level::level >= ::mapdelta::log::GetLevel()) {            \
      std::ostringstream md_log_stream_;                                           \
      md_log_stream_ << expr;                                                      \
      ::mapdelta::log::Write(::mapdelta::log::Level::level, md_log_stream_.str()); \
    }                                                                              \
  } while (false)
