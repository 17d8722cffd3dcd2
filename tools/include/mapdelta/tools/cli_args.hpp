#pragma once
// A small strict command-line parser for the mapdelta tools: positionals, "--name value"
// options and "--flag" switches; unknown options and missing values are errors (PDAL-style).
#include <map>
#include <set>
#include <string>
#include <vector>

namespace mapdelta::tools {

class CliArgs {
 public:
  // `options` take a value, `flags` do not. Throws Error(kInvalidArgument) naming the problem.
  CliArgs(const std::vector<std::string>& args, const std::set<std::string>& options,
          const std::set<std::string>& flags);
  const std::vector<std::string>& positionals() const { return positionals_; }
  bool Has(const std::string& name) const;
  std::string Get(const std::string& name, const std::string& fallback) const;
  std::string Require(const std::string& name) const;  // throws when missing
  double GetDouble(const std::string& name, double fallback) const;  // throws when not a number
  int GetInt(const std::string& name, int fallback) const;

 private:
  std::vector<std::string> positionals_;
  std::map<std::string, std::string> values_;
  std::set<std::string> flags_;
};

}  // namespace mapdelta::tools
