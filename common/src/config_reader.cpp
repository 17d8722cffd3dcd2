// The strict YAML config reader behind config_reader.hpp, on yaml-cpp: walks the document
// against the declared key paths, collecting every problem before throwing once.
#include "mapdelta/common/config_reader.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <type_traits>

#include "mapdelta/common/error.hpp"

namespace mapdelta {
namespace {

std::string Text(const YAML::Node& node) {
  return node.IsScalar() ? node.Scalar() : "a non-scalar";
}

template <typename T>
std::string Format(T v) {
  std::ostringstream o;
  o.precision(12);
  o << v;
  return o.str();
}

// Reads one scalar into the entry's variable; returns the problem or "".
std::string ReadScalar(const ConfigSchema::Entry& e, const YAML::Node& node) {
  const char* expected = std::visit(
      [](auto* p) -> const char* {
        using T = std::remove_pointer_t<decltype(p)>;
        if constexpr (std::is_same_v<T, double>) return "a number";
        if constexpr (std::is_same_v<T, bool>) return "true or false";
        if constexpr (std::is_same_v<T, std::string>) return "a text";
        return "an integer";
      },
      e.value);
  if (!node.IsScalar()) return e.path + ": expected " + expected + ", got " + Text(node);
  try {
    std::visit(
        [&](auto* p) {
          using T = std::remove_pointer_t<decltype(p)>;
          if constexpr (std::is_same_v<T, int>) {
            const auto v = node.as<int64_t>();
            // Out-of-int values are clamped so that Problems() reports them as out of range.
            *p = static_cast<int>(std::clamp<int64_t>(v, INT32_MIN, INT32_MAX));
          } else {
            *p = node.as<T>();
          }
        },
        e.value);
  } catch (const YAML::Exception&) {
    return e.path + ": expected " + expected + ", got '" + node.Scalar() + "'";
  }
  return "";
}

bool IsSection(const ConfigSchema& schema, const std::string& path) {
  const std::string prefix = path + ".";
  return std::any_of(schema.entries().begin(), schema.entries().end(),
                     [&](const auto& e) { return e.path.rfind(prefix, 0) == 0; });
}

void ReadMap(const YAML::Node& map, const std::string& prefix, const ConfigSchema& schema,
             std::vector<std::string>* problems) {
  for (const auto& kv : map) {
    const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : "?";
    const std::string path = prefix.empty() ? key : prefix + "." + key;
    const auto entry = std::find_if(schema.entries().begin(), schema.entries().end(),
                                    [&](const auto& e) { return e.path == path; });
    if (entry != schema.entries().end()) {
      const std::string problem = ReadScalar(*entry, kv.second);
      if (!problem.empty()) problems->push_back(problem);
    } else if (IsSection(schema, path)) {
      if (kv.second.IsMap()) {
        ReadMap(kv.second, path, schema, problems);
      } else if (!kv.second.IsNull()) {  // "section:" alone keeps its defaults
        problems->push_back(path + ": expected a mapping of keys");
      }
    } else {
      problems->push_back(path + (prefix.empty() ? ": unknown section" : ": unknown key"));
    }
  }
}

std::string JoinProblems(const std::string& what, const std::vector<std::string>& problems) {
  std::string message = what + ": " + std::to_string(problems.size()) + " problem(s):";
  for (const auto& p : problems) message += "\n  - " + p;
  return message;
}

}  // namespace

ConfigSchema& ConfigSchema::Field(const std::string& path, int* value, int64_t min, int64_t max) {
  entries_.push_back({path, value, static_cast<double>(min), static_cast<double>(max), {}});
  return *this;
}
ConfigSchema& ConfigSchema::Field(const std::string& path, int64_t* value, int64_t min,
                                  int64_t max) {
  entries_.push_back({path, value, static_cast<double>(min), static_cast<double>(max), {}});
  return *this;
}
ConfigSchema& ConfigSchema::Field(const std::string& path, double* value, double min, double max) {
  entries_.push_back({path, value, min, max, {}});
  return *this;
}
ConfigSchema& ConfigSchema::Field(const std::string& path, bool* value) {
  entries_.push_back({path, value, 0, 0, {}});
  return *this;
}
ConfigSchema& ConfigSchema::Field(const std::string& path, std::string* value,
                                  std::vector<std::string> choices) {
  entries_.push_back({path, value, 0, 0, std::move(choices)});
  return *this;
}
ConfigSchema& ConfigSchema::OptionalField(const std::string& path, std::string* value) {
  entries_.push_back({path, value, 0, 0, {}, true});
  return *this;
}
ConfigSchema& ConfigSchema::Rule(std::function<std::string()> rule) {
  rules_.push_back(std::move(rule));
  return *this;
}

std::vector<std::string> ConfigSchema::Problems() const {
  std::vector<std::string> problems;
  for (const auto& e : entries_) {
    std::visit(
        [&](auto* p) {
          using T = std::remove_pointer_t<decltype(p)>;
          if constexpr (std::is_same_v<T, std::string>) {
            if (!e.choices.empty() &&
                std::find(e.choices.begin(), e.choices.end(), *p) == e.choices.end()) {
              std::string list;
              for (const auto& c : e.choices) list += (list.empty() ? "" : ", ") + c;
              problems.push_back(e.path + ": expected one of " + list + ", got '" + *p + "'");
            } else if (e.choices.empty() && p->empty() && !e.may_be_empty) {
              problems.push_back(e.path + ": must not be empty");
            }
          } else if constexpr (!std::is_same_v<T, bool>) {
            const double v = static_cast<double>(*p);
            if (!(v >= e.min && v <= e.max)) {
              problems.push_back(e.path + ": " + Format(*p) + " is outside [" + Format(e.min) +
                                 ", " + Format(e.max) + "]");
            }
          }
        },
        e.value);
  }
  for (const auto& rule : rules_) {
    const std::string problem = rule();
    if (!problem.empty()) problems.push_back(problem);
  }
  return problems;
}

void ReadConfigYaml(const std::string& text, const std::string& what, const ConfigSchema& schema) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw Error(ErrorCode::kInvalidArgument, what + ": not valid YAML: " + e.what());
  }
  std::vector<std::string> problems;
  if (root.IsMap()) {
    ReadMap(root, "", schema, &problems);
  } else if (!root.IsNull()) {
    throw Error(ErrorCode::kInvalidArgument,
                what + ": expected a mapping of sections at the top level");
  }
  // Ranges, choices and rules on the values as read (a field whose text did not parse keeps
  // its valid default, so each problem is reported once).
  for (auto& p : schema.Problems()) problems.push_back(std::move(p));
  if (!problems.empty()) throw Error(ErrorCode::kInvalidArgument, JoinProblems(what, problems));
}

void ReadConfigFile(const std::string& path, const ConfigSchema& schema) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorCode::kInvalidArgument, path + ": cannot read config file");
  std::ostringstream text;
  text << in.rdbuf();
  ReadConfigYaml(text.str(), path, schema);
}

void ThrowIfInvalid(const ConfigSchema& schema, const std::string& what) {
  const std::vector<std::string> problems = schema.Problems();
  if (!problems.empty()) throw Error(ErrorCode::kInvalidArgument, JoinProblems(what, problems));
}

std::string ConfigToYaml(const ConfigSchema& schema) {
  YAML::Emitter out;
  out.SetDoublePrecision(12);
  out << YAML::BeginMap;
  std::vector<std::string> open;  // the sections of the previous entry
  for (const auto& e : schema.entries()) {
    std::vector<std::string> parts;
    std::stringstream in(e.path);
    for (std::string part; std::getline(in, part, '.');) parts.push_back(part);
    const std::vector<std::string> sections(parts.begin(), parts.end() - 1);
    size_t common = 0;
    while (common < open.size() && common < sections.size() && open[common] == sections[common])
      ++common;
    for (size_t i = open.size(); i > common; --i) out << YAML::EndMap;
    for (size_t i = common; i < sections.size(); ++i)
      out << YAML::Key << sections[i] << YAML::Value << YAML::BeginMap;
    open = sections;
    out << YAML::Key << parts.back() << YAML::Value;
    std::visit([&](auto* p) { out << *p; }, e.value);
  }
  for (size_t i = 0; i < open.size(); ++i) out << YAML::EndMap;
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace mapdelta
