#pragma once
// Tiny argument parser for the subcommands: positionals plus --key value / --flag options.
// Unknown options are errors (reported by the caller with its usage text).
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace mapdelta::client::app {

struct Args {
  std::vector<std::string> positional;
  std::map<std::string, std::string> options;
  bool help = false;

  bool Has(const std::string& key) const { return options.count(key) > 0; }
  std::string Get(const std::string& key, const std::string& fallback = "") const {
    const auto it = options.find(key);
    return it == options.end() ? fallback : it->second;
  }
};

// with_value: options taking a value; flags: options without. Throws std::invalid_argument.
inline Args ParseArgs(int argc, char** argv, const std::set<std::string>& with_value,
                      const std::set<std::string>& flags = {}) {
  Args args;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      args.help = true;
    } else if (a.rfind("--", 0) == 0) {
      const std::string key = a.substr(2);
      if (flags.count(key)) {
        args.options[key] = "1";
      } else if (with_value.count(key)) {
        if (i + 1 >= argc) throw std::invalid_argument("option --" + key + " needs a value");
        args.options[key] = argv[++i];
      } else {
        throw std::invalid_argument("unknown option " + a);
      }
    } else {
      args.positional.push_back(a);
    }
  }
  return args;
}

}  // namespace mapdelta::client::app
