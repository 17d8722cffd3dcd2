#include "mapdelta/tools/cli_args.hpp"

#include <cmath>
#include <cstdlib>

#include "mapdelta/common/error.hpp"

namespace mapdelta::tools {

CliArgs::CliArgs(const std::vector<std::string>& args, const std::set<std::string>& options,
                 const std::set<std::string>& flags) {
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a.rfind("--", 0) != 0 || a == "--") {
      positionals_.push_back(a);
      continue;
    }
    const std::string name = a.substr(2);
    if (flags.count(name)) {
      flags_.insert(name);
    } else if (options.count(name)) {
      if (i + 1 >= args.size()) throw Error(ErrorCode::kInvalidArgument, "option --" + name + " needs a value");
      values_[name] = args[++i];
    } else {
      throw Error(ErrorCode::kInvalidArgument, "unknown option " + a + " (see --help)");
    }
  }
}

bool CliArgs::Has(const std::string& name) const { return values_.count(name) || flags_.count(name); }

std::string CliArgs::Get(const std::string& name, const std::string& fallback) const {
  const auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second;
}

std::string CliArgs::Require(const std::string& name) const {
  const auto it = values_.find(name);
  if (it == values_.end()) throw Error(ErrorCode::kInvalidArgument, "missing required option --" + name);
  return it->second;
}

double CliArgs::GetDouble(const std::string& name, double fallback) const {
  const auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  char* end = nullptr;
  const double v = std::strtod(it->second.c_str(), &end);
  if (it->second.empty() || *end != '\0' || !std::isfinite(v)) {
    throw Error(ErrorCode::kInvalidArgument, "--" + name + " must be a number (got '" + it->second + "')");
  }
  return v;
}

int CliArgs::GetInt(const std::string& name, int fallback) const {
  const double v = GetDouble(name, fallback);
  if (v != std::floor(v) || std::abs(v) > 1e9) {
    throw Error(ErrorCode::kInvalidArgument, "--" + name + " must be an integer");
  }
  return static_cast<int>(v);
}

}  // namespace mapdelta::tools
