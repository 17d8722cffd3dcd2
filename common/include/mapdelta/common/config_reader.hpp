#pragma once
// The one strict YAML config reader of mapdelta (client and server configs). A component
// declares its config struct's fields once, in a ConfigSchema bound to an instance; the
// struct declaration keeps the defaults and units. Reading then
//   - rejects unknown sections and keys, wrong types and out-of-range values,
//   - reports every problem at once, each with its key path, in one
//     Error(kInvalidArgument) "FILE: N problem(s):\n  - stereo.block_size: must be odd",
//     so that programs exit with the usage/config code (cli::kExitUsage),
//   - and the effective config is echoed as YAML that reads back to the same values.
// yaml-cpp stays inside src/config_reader.cpp.
#include <cstdint>
#include <functional>
#include <string>
#include <variant>
#include <vector>

namespace mapdelta {

class ConfigSchema {
 public:
  // Fields by key path "section.key" in declaration order (the echo's order). The bound
  // variable holds the default on entry. Ranges are inclusive.
  ConfigSchema& Field(const std::string& path, int* value, int64_t min, int64_t max);
  ConfigSchema& Field(const std::string& path, int64_t* value, int64_t min, int64_t max);
  ConfigSchema& Field(const std::string& path, double* value, double min, double max);
  ConfigSchema& Field(const std::string& path, bool* value);
  // A string; `choices` empty: any non-empty text.
  ConfigSchema& Field(const std::string& path, std::string* value,
                      std::vector<std::string> choices = {});
  // A string that may be empty: a setting only one mode needs (a Rule says when it is required).
  ConfigSchema& OptionalField(const std::string& path, std::string* value);
  // A rule across fields, checked once every field is read: returns the problem
  // ("stereo.block_size: must be odd") or "" when the values are fine.
  ConfigSchema& Rule(std::function<std::string()> rule);

  // Every problem of the bound values as they are now (ranges, choices, rules).
  std::vector<std::string> Problems() const;

  struct Entry {
    std::string path;
    std::variant<int*, int64_t*, double*, bool*, std::string*> value;
    double min = 0, max = 0;  // numbers only
    std::vector<std::string> choices;
    bool may_be_empty = false;  // strings only
  };
  const std::vector<Entry>& entries() const { return entries_; }

 private:
  std::vector<Entry> entries_;
  std::vector<std::function<std::string()>> rules_;
};

// Reads YAML text (`what` names it in the messages, e.g. the file name) into the schema's
// variables; an empty document keeps every default. Throws Error(kInvalidArgument) listing
// every problem; the variables are then unspecified.
void ReadConfigYaml(const std::string& text, const std::string& what, const ConfigSchema& schema);
// The same from a file; an unreadable file is a config error too (Error(kInvalidArgument)).
void ReadConfigFile(const std::string& path, const ConfigSchema& schema);
// Throws Error(kInvalidArgument) "`what`: N problem(s): ..." when Problems() is not empty.
void ThrowIfInvalid(const ConfigSchema& schema, const std::string& what);
// The bound values as YAML ("section:\n  key: value"), loadable again by ReadConfigYaml.
std::string ConfigToYaml(const ConfigSchema& schema);

}  // namespace mapdelta
