#pragma once
// Scratch folders for tests. ctest runs tests in parallel, one process each, and several
// checkouts may be tested on one machine at once: a fixed name under /tmp collides, so every
// folder carries the process id.
#include <unistd.h>

#include <filesystem>
#include <string>

namespace mapdelta::testing {

// An empty folder <tmp>/<name>_<pid>, created fresh (any earlier content removed).
inline std::filesystem::path FreshTempDir(const std::string& name) {
  const auto dir =
      std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// A file path <tmp>/<pid>_<file_name> (the file itself is not created).
inline std::filesystem::path TempFilePath(const std::string& file_name) {
  return std::filesystem::temp_directory_path() / (std::to_string(::getpid()) + "_" + file_name);
}

}  // namespace mapdelta::testing
