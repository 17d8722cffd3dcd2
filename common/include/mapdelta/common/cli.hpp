#pragma once
// The one command-line parser of every mapdelta program (client, server, sim, tools, VIO,
// benchmarks), so that options, --help and errors read alike everywhere:
//   - "--name VALUE" or "--name=VALUE" options, "--flag" switches, positionals;
//   - unknown options, missing values, values of the wrong type and missing required options
//     are usage errors that name the option: Error(kInvalidArgument) with the message
//     "--port: expected an integer, got 'abc' (see 'mapdelta-server serve --help')";
//   - --help / -h writes the generated help to the stream the caller names.
// Built on CLI11 (Debian's libcli11-dev), which stays inside src/cli.cpp: it is a large
// header and this one is included by every main.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace mapdelta::cli {

// Exit codes of every mapdelta program (their --help texts promise these).
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;  // runtime failure, unreadable or malformed input file
inline constexpr int kExitUsage = 2;    // bad command line or configuration
// The closing line of every --help.
inline constexpr const char* kExitCodesFooter =
    "Exit codes: 0 success, 1 runtime failure or unreadable/malformed input, 2 usage or "
    "configuration error.";

class Parser {
 public:
  // `program`: what the user typed to get here, e.g. "mapdelta-client run" (names the help
  // and the errors); `description`: the paragraph above the option list.
  Parser(std::string program, std::string description);
  ~Parser();
  Parser(const Parser&) = delete;
  Parser& operator=(const Parser&) = delete;

  // "--name VALUE". The variable holds the default on entry (shown in --help) and the value
  // after Parse. `value_name` is the placeholder in --help ("FILE", "N", "M").
  Parser& Option(const std::string& name, std::string* value, const std::string& help,
                 const std::string& value_name = "TEXT");
  Parser& Option(const std::string& name, double* value, const std::string& help,
                 const std::string& value_name = "X");
  Parser& Option(const std::string& name, int* value, const std::string& help,
                 const std::string& value_name = "N");
  Parser& Option(const std::string& name, int64_t* value, const std::string& help,
                 const std::string& value_name = "N");
  Parser& Option(const std::string& name, uint64_t* value, const std::string& help,
                 const std::string& value_name = "N");
  // "--name VALUE", repeatable: every value in order.
  Parser& Repeated(const std::string& name, std::vector<std::string>* values,
                   const std::string& help, const std::string& value_name = "TEXT");
  Parser& Repeated(const std::string& name, std::vector<double>* values, const std::string& help,
                   const std::string& value_name = "X");
  // "--name": true when given.
  Parser& Flag(const std::string& name, bool* value, const std::string& help);
  // A required positional argument, in declaration order.
  Parser& Positional(const std::string& name, std::string* value, const std::string& help);
  // Marks options (declared before) as required: Parse fails naming all that are missing.
  Parser& Require(const std::vector<std::string>& names);
  // The value must be one of `choices` (listed in --help and in the error).
  Parser& Choices(const std::string& name, const std::vector<std::string>& choices);
  // Text printed under the option list (examples, exit codes, notes).
  Parser& Footer(const std::string& text);

  // Parses `args` (without the program name). Returns false when --help was asked for (the
  // help is written to `help_out`; the caller returns kExitOk). Throws Error(kInvalidArgument)
  // naming the option for every usage error; the variables are then unspecified.
  bool Parse(const std::vector<std::string>& args, std::ostream& help_out);
  bool Parse(int argc, const char* const* argv, std::ostream& help_out);  // skips argv[0]

  // Whether the option was given on the command line (its value may equal the default).
  bool Given(const std::string& name) const;
  std::string Help() const;
  const std::string& program() const { return program_; }

 private:
  struct Impl;
  std::string program_;
  std::unique_ptr<Impl> impl_;
};

// A usage error found after parsing (e.g. two options that exclude each other): throws
// Error(kInvalidArgument) with `message` and the --help hint of `program`.
[[noreturn]] void FailUsage(const std::string& program, const std::string& message);

// Runs a program's body and turns exceptions into one line "<program>: error: <message>" on
// stderr and an exit code: kExitUsage for usage and configuration errors (Error with
// kInvalidArgument), kExitFailure for everything else.
int RunMain(const std::string& program, const std::function<int()>& body);

// For a main that parses first and runs outside RunMain (the benchmarks): nullopt to go on;
// otherwise the exit code, after the help (stdout) or the usage error (stderr, as RunMain).
// `check` runs after a successful parse and may FailUsage.
std::optional<int> ParseMain(Parser& parser, int argc, const char* const* argv,
                             const std::function<void()>& check = {});

}  // namespace mapdelta::cli
