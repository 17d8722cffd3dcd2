#pragma once
// Progress of long client commands on stderr: redrawn in place on a terminal; elsewhere (a
// log file, CI, a pipe) one whole line per change, at most one per `min_interval_s`, so that
// the log stays readable and holds no carriage returns.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>

namespace mapdelta::client::app {

class ProgressLine {
 public:
  explicit ProgressLine(double min_interval_s = 5.0)
      : tty_(isatty(STDERR_FILENO) == 1), min_interval_s_(min_interval_s) {}
  ~ProgressLine() { Finish(); }

  void Update(const std::string& text) {
    if (text == last_) return;
    const auto now = std::chrono::steady_clock::now();
    if (tty_) {
      std::fprintf(stderr, "\r%s ", text.c_str());
      open_ = true;
    } else {
      if (printed_ && std::chrono::duration<double>(now - last_print_).count() < min_interval_s_)
        return;
      std::fprintf(stderr, "%s\n", text.c_str());
    }
    std::fflush(stderr);
    last_ = text;
    last_print_ = now;
    printed_ = true;
  }
  // The last state on its own line (also when it changed within the interval), then done.
  void Finish(const std::string& text = "") {
    if (!text.empty() && text != last_) {
      std::fprintf(stderr, tty_ ? "\r%s \n" : "%s\n", text.c_str());
      open_ = false;
      last_ = text;
    }
    if (open_) std::fprintf(stderr, "\n");
    open_ = false;
  }

 private:
  bool tty_;
  double min_interval_s_;
  bool printed_ = false, open_ = false;
  std::string last_;
  std::chrono::steady_clock::time_point last_print_;
};

}  // namespace mapdelta::client::app
