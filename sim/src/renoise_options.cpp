// Command line of `mapdelta-sim renoise` (see renoise.hpp).
#include <cstdlib>
#include <sstream>

#include "mapdelta/common/error.hpp"
#include "mapdelta/sim/renoise.hpp"

namespace mapdelta::sim {

std::string RenoiseHelpText() {
  return "usage: mapdelta-sim renoise --from CLEAN --out DIR [--noise small|big|none] [--seed N]\n"
         "                            [--sequences A,B] [--threads N] [--quiet]\n"
         "  New sensor noise on a dataset rendered with --noise none, without rendering again:\n"
         "  image noise on the stored clean images, IMU noise on the clean IMU samples, ground\n"
         "  truth biases rewritten, scenes and depth0 hard-linked. With --seed equal to the clean\n"
         "  dataset's seed the output is byte-identical to 'mapdelta-sim --noise NAME' directly.\n"
         "  --from DIR       dataset written by mapdelta-sim with --noise none\n"
         "  --out DIR        new dataset (may be the same path as a previous renoise output)\n"
         "  --noise NAME     none | small | big (default small)\n"
         "  --seed N         noise seed (default 1); the city and trajectories keep CLEAN's seed\n"
         "  --sequences L    comma-separated sequences (default: all in CLEAN/sequences)\n"
         "  --threads N      worker threads (default: all cores)\n"
         "  --quiet          no progress\n";
}

RenoiseOptions ParseRenoiseArgs(const std::vector<std::string>& args, bool* help, bool* quiet) {
  RenoiseOptions o;
  *help = false;
  *quiet = false;
  std::vector<std::string> problems;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--help" || a == "-h") {
      *help = true;
      continue;
    }
    if (a == "--quiet") {
      *quiet = true;
      continue;
    }
    if (i + 1 >= args.size()) {
      problems.push_back(a + " needs a value");
      continue;
    }
    const std::string v = args[++i];
    char* end = nullptr;
    if (a == "--from") {
      o.from_dir = v;
    } else if (a == "--out") {
      o.out_dir = v;
    } else if (a == "--noise") {
      if (!ParseNoiseLevel(v, &o.noise)) problems.push_back("--noise '" + v + "': expected none, small or big");
    } else if (a == "--seed") {
      const unsigned long long s = std::strtoull(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0' || v[0] == '-') problems.push_back("--seed '" + v + "': expected a non-negative integer");
      o.seed = s;
    } else if (a == "--threads") {
      const long t = std::strtol(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0' || t < 0 || t > 1024) problems.push_back("--threads '" + v + "': expected 0..1024");
      o.threads = static_cast<int>(t);
    } else if (a == "--sequences") {
      std::stringstream ss(v);
      for (std::string s; std::getline(ss, s, ',');) {
        if (!s.empty()) o.sequences.push_back(s);
      }
      if (o.sequences.empty()) problems.push_back("--sequences '" + v + "': empty list");
    } else {
      problems.push_back("unknown option '" + a + "'");
      --i;  // it was not followed by its value
    }
  }
  if (!*help) {
    if (o.from_dir.empty()) problems.push_back("--from is required");
    if (o.out_dir.empty()) problems.push_back("--out is required");
  }
  if (!problems.empty()) {
    std::string msg = "renoise: ";
    for (size_t i = 0; i < problems.size(); ++i) msg += (i ? "; " : "") + problems[i];
    throw Error(ErrorCode::kInvalidArgument, msg);
  }
  return o;
}

}  // namespace mapdelta::sim
