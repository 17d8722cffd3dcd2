#include "web_root.hpp"

#include <algorithm>
#include <filesystem>
#include <system_error>

namespace mapdelta::server {
namespace fs = std::filesystem;

std::string ResolveWebRoot(const std::string& configured, const std::string& exe_path,
                           const std::string& build_dir, const std::string& source_web_dist) {
  if (configured.empty() || configured == "off") return "";
  if (configured != "auto") return configured;
  const fs::path exe = fs::path(exe_path).lexically_normal();
  const fs::path build = fs::path(build_dir).lexically_normal();
  // Inside the build tree: the exe path starts with every component of build_dir.
  const bool in_build_tree =
      !build_dir.empty() &&
      std::mismatch(build.begin(), build.end(), exe.begin(), exe.end()).first == build.end();
  if (in_build_tree) return source_web_dist;
  return (exe.parent_path().parent_path() / "share" / "mapdelta" / "web").string();
}

std::string CurrentExecutablePath() {
  std::error_code error;
  const fs::path exe = fs::read_symlink("/proc/self/exe", error);
  return error ? std::string() : exe.string();
}

}  // namespace mapdelta::server
