// The command-line parser behind cli.hpp: CLI11 splits the command line (--name=value,
// "--" and negative numbers as values, the help layout); this file adds the house rules on
// top: one error wording that names the option, unknown options reported before missing
// ones, typed values converted here so that "abc" for a number says what was expected.
#include "mapdelta/common/cli.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <sstream>
#include <type_traits>

#include "mapdelta/common/error.hpp"

namespace mapdelta::cli {
namespace {

bool ToInt64(const std::string& s, int64_t* v) {
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  const long long parsed = std::strtoll(s.c_str(), &end, 10);
  if (errno == ERANGE || *end != '\0') return false;
  *v = parsed;
  return true;
}

bool ToInt(const std::string& s, int* v) {
  int64_t n = 0;
  if (!ToInt64(s, &n) || n < std::numeric_limits<int>::min() || n > std::numeric_limits<int>::max())
    return false;
  *v = static_cast<int>(n);
  return true;
}

bool ToUint64(const std::string& s, uint64_t* v) {
  if (s.empty() || s[0] == '-') return false;
  char* end = nullptr;
  errno = 0;
  const unsigned long long parsed = std::strtoull(s.c_str(), &end, 10);
  if (errno == ERANGE || *end != '\0') return false;
  *v = parsed;
  return true;
}

bool ToDouble(const std::string& s, double* v) {
  if (s.empty()) return false;
  char* end = nullptr;
  const double parsed = std::strtod(s.c_str(), &end);
  if (*end != '\0' || !std::isfinite(parsed)) return false;
  *v = parsed;
  return true;
}

std::string Join(const std::vector<std::string>& items, const std::string& separator) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : separator) + item;
  return out;
}

std::string Expected(const std::string& what, const std::string& got) {
  return "expected " + what + ", got '" + got + "'";
}

template <typename T>
std::string FormatDefault(T v) {
  if constexpr (std::is_same_v<T, double>) {
    std::ostringstream o;
    o << v;
    return o.str();
  } else {
    return std::to_string(v);
  }
}

// "--name" for options, "NAME" for positionals: how the user sees them.
std::string Shown(const std::string& name, bool positional) {
  return positional ? name : "--" + name;
}

}  // namespace

struct Parser::Impl {
  struct Entry {
    std::string name;
    bool positional = false;
    bool flag = false;
    bool required = false;
    std::vector<std::string> choices;
    CLI::Option* option = nullptr;
    // Converts the given values (one, or all for Repeated) into the caller's variable;
    // returns the problem ("expected a number, got 'abc'") when a value does not convert.
    std::function<std::string(const std::vector<std::string>&)> assign;
  };

  explicit Impl(const std::string& program, const std::string& description)
      : app(description, program) {
    app.allow_extras(true);  // reported by Parse in our words, before missing options
    app.set_help_flag("-h,--help", "print this help and exit");
  }

  Entry& Find(const std::string& name) {
    for (auto& e : entries) {
      if (e.name == name) return e;
    }
    throw Error(ErrorCode::kInternal, "cli: option '" + name + "' was not declared");
  }
  const Entry* FindGiven(const std::string& name) const {
    for (const auto& e : entries) {
      if (e.name == name) return &e;
    }
    return nullptr;
  }

  Entry& AddValue(const std::string& name, const std::string& help, const std::string& value_name,
                  const std::string& default_text) {
    Entry e;
    e.name = name;
    e.option = app.add_option("--" + name, CLI::callback_t{}, help);
    e.option->type_name(value_name)->type_size(1)->expected(1);
    e.option->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
    if (!default_text.empty()) e.option->default_str(default_text);
    entries.push_back(std::move(e));
    return entries.back();
  }

  // A typed "--name VALUE": `convert` parses the text, `what` says what it expected.
  template <typename T>
  void AddNumber(const std::string& name, T* value, const std::string& help,
                 const std::string& value_name, bool (*convert)(const std::string&, T*),
                 const char* what) {
    AddValue(name, help, value_name, FormatDefault(*value)).assign =
        [value, convert, what](const std::vector<std::string>& v) {
          return convert(v.back(), value) ? std::string() : Expected(what, v.back());
        };
  }

  CLI::App app;
  std::vector<Entry> entries;
};

Parser::Parser(std::string program, std::string description)
    : program_(std::move(program)), impl_(std::make_unique<Impl>(program_, description)) {}

Parser::~Parser() = default;

Parser& Parser::Option(const std::string& name, std::string* value, const std::string& help,
                       const std::string& value_name) {
  impl_->AddValue(name, help, value_name, *value).assign =
      [value](const std::vector<std::string>& v) {
        *value = v.back();
        return std::string();
      };
  return *this;
}

Parser& Parser::Option(const std::string& name, double* value, const std::string& help,
                       const std::string& value_name) {
  impl_->AddNumber(name, value, help, value_name, &ToDouble, "a number");
  return *this;
}

Parser& Parser::Option(const std::string& name, int* value, const std::string& help,
                       const std::string& value_name) {
  impl_->AddNumber(name, value, help, value_name, &ToInt, "an integer");
  return *this;
}

Parser& Parser::Option(const std::string& name, int64_t* value, const std::string& help,
                       const std::string& value_name) {
  impl_->AddNumber(name, value, help, value_name, &ToInt64, "an integer");
  return *this;
}

Parser& Parser::Option(const std::string& name, uint64_t* value, const std::string& help,
                       const std::string& value_name) {
  impl_->AddNumber(name, value, help, value_name, &ToUint64, "a non-negative integer");
  return *this;
}

Parser& Parser::Repeated(const std::string& name, std::vector<std::string>* values,
                         const std::string& help, const std::string& value_name) {
  auto& e = impl_->AddValue(name, help + " (repeatable)", value_name, "");
  e.option->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  e.assign = [values](const std::vector<std::string>& v) {
    *values = v;
    return std::string();
  };
  return *this;
}

Parser& Parser::Repeated(const std::string& name, std::vector<double>* values,
                         const std::string& help, const std::string& value_name) {
  auto& e = impl_->AddValue(name, help + " (repeatable)", value_name, "");
  e.option->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  e.assign = [values](const std::vector<std::string>& v) {
    values->clear();
    for (const auto& text : v) {
      double x = 0;
      if (!ToDouble(text, &x)) return Expected("a number", text);
      values->push_back(x);
    }
    return std::string();
  };
  return *this;
}

Parser& Parser::Flag(const std::string& name, bool* value, const std::string& help) {
  Impl::Entry e;
  e.name = name;
  e.flag = true;
  e.option = impl_->app.add_flag("--" + name, help);
  e.option->disable_flag_override();
  e.assign = [value](const std::vector<std::string>&) {
    *value = true;
    return std::string();
  };
  impl_->entries.push_back(std::move(e));
  return *this;
}

Parser& Parser::Positional(const std::string& name, std::string* value, const std::string& help) {
  Impl::Entry e;
  e.name = name;
  e.positional = true;
  e.required = true;
  e.option = impl_->app.add_option(name, CLI::callback_t{}, help);
  e.option->type_name("")->type_size(1)->expected(1);
  e.assign = [value](const std::vector<std::string>& v) {
    *value = v.back();
    return std::string();
  };
  impl_->entries.push_back(std::move(e));
  return *this;
}

Parser& Parser::Require(const std::vector<std::string>& names) {
  for (const auto& name : names) {
    auto& e = impl_->Find(name);
    e.required = true;
    e.option->description(e.option->get_description() + " (required)");
  }
  return *this;
}

Parser& Parser::Choices(const std::string& name, const std::vector<std::string>& choices) {
  auto& e = impl_->Find(name);
  e.choices = choices;
  e.option->type_name(Join(choices, "|"));
  return *this;
}

Parser& Parser::Footer(const std::string& text) {
  impl_->app.footer(text);
  return *this;
}

bool Parser::Parse(int argc, const char* const* argv, std::ostream& help_out) {
  return Parse(std::vector<std::string>(argv + std::min(argc, 1), argv + argc), help_out);
}

bool Parser::Parse(const std::vector<std::string>& args, std::ostream& help_out) {
  // Step 1: CLI11 splits the command line (it takes the arguments last first).
  std::vector<std::string> reversed(args.rbegin(), args.rend());
  try {
    impl_->app.parse(reversed);
  } catch (const CLI::CallForHelp&) {
    help_out << Help();
    return false;
  } catch (const CLI::ArgumentMismatch& e) {
    // A missing value reads "--port: 1 required N missing"; others (a value for a flag) as is.
    const std::string what = e.what();
    if (what.find("flag override") != std::string::npos) {
      FailUsage(program_, "--" + what.substr(0, what.find(' ')) + " takes no value");
    }
    if (what.find("missing") == std::string::npos) FailUsage(program_, what);
    FailUsage(program_, what.substr(0, what.find(':')) + " needs a value");
  } catch (const CLI::ParseError& e) {
    FailUsage(program_, e.what());
  }
  // Step 2: what CLI11 did not recognize.
  std::vector<std::string> extras = impl_->app.remaining();
  extras.erase(std::remove(extras.begin(), extras.end(), "--"), extras.end());
  if (!extras.empty()) {
    const std::string& first = extras.front();
    if (first.size() > 1 && first[0] == '-') {
      FailUsage(program_, "unknown option " + first.substr(0, first.find('=')));
    }
    FailUsage(program_, "unexpected argument '" + first + "'");
  }
  // Step 3: required options and positionals, all missing ones at once.
  std::vector<std::string> missing;
  for (const auto& e : impl_->entries) {
    if (e.required && e.option->count() == 0) missing.push_back(Shown(e.name, e.positional));
  }
  if (!missing.empty()) FailUsage(program_, "missing " + Join(missing, ", "));
  // Step 4: values into the caller's variables, converted and checked.
  for (const auto& e : impl_->entries) {
    if (e.option->count() == 0) continue;
    const std::vector<std::string> values =
        e.flag ? std::vector<std::string>{} : e.option->results();
    const std::string shown = Shown(e.name, e.positional);
    for (const auto& v : values) {
      if (!e.choices.empty() &&
          std::find(e.choices.begin(), e.choices.end(), v) == e.choices.end()) {
        FailUsage(program_, shown + ": " + Expected(Join(e.choices, ", "), v));
      }
    }
    const std::string problem = e.assign(values);
    if (!problem.empty()) FailUsage(program_, shown + ": " + problem);
  }
  return true;
}

bool Parser::Given(const std::string& name) const {
  const Impl::Entry* e = impl_->FindGiven(name);
  if (!e) throw Error(ErrorCode::kInternal, "cli: option '" + name + "' was not declared");
  return e->option->count() > 0;
}

std::string Parser::Help() const { return impl_->app.help(); }

void FailUsage(const std::string& program, const std::string& message) {
  throw Error(ErrorCode::kInvalidArgument, message + " (see '" + program + " --help')");
}

int RunMain(const std::string& program, const std::function<int()>& body) {
  try {
    return body();
  } catch (const Error& e) {
    std::cerr << program << ": error: " << e.what() << "\n";
    return e.code() == ErrorCode::kInvalidArgument ? kExitUsage : kExitFailure;
  } catch (const std::exception& e) {
    std::cerr << program << ": error: " << e.what() << "\n";
    return kExitFailure;
  }
}

std::optional<int> ParseMain(Parser& parser, int argc, const char* const* argv,
                             const std::function<void()>& check) {
  bool run = false;
  const int code = RunMain(parser.program(), [&] {
    run = parser.Parse(argc, argv, std::cout);
    if (run && check) check();
    return kExitOk;
  });
  if (code != kExitOk || !run) return code;
  return std::nullopt;
}

}  // namespace mapdelta::cli
