#pragma once
// Where mapdelta-server finds the web map's static files (web/, built into web/dist).
#include <string>

namespace mapdelta::server {

// `configured` is http.web_root or --web-root: "off" (or "") serves no page, a folder serves
// that folder, "auto" picks by where the binary runs from:
//   - a binary inside `build_dir` (the build tree it was built in): `source_web_dist`, the
//     source tree's web/dist, which only exists there;
//   - any other binary (installed, e.g. /usr/bin/mapdelta-server): <exe dir>/../share/mapdelta/web,
//     where `cmake --install` and the Debian package put the page.
// Returns "" for no page.
std::string ResolveWebRoot(const std::string& configured, const std::string& exe_path,
                           const std::string& build_dir, const std::string& source_web_dist);

// The running binary's path (/proc/self/exe), "" when unknown.
std::string CurrentExecutablePath();

}  // namespace mapdelta::server
