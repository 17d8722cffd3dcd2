// The one command-line parser (common/cli.hpp): what every mapdelta program accepts and how
// its errors read (they name the option and what was expected).
#include <gtest/gtest.h>

#include <sstream>

#include "mapdelta/common/cli.hpp"
#include "mapdelta/common/error.hpp"

namespace mapdelta::cli {
namespace {

// A parser shaped like a real command: a positional, typed options, a flag, a choice.
struct Command {
  std::string dir, config, align = "se3";
  int port = 8080;
  double yaw = 0.05;
  uint64_t seed = 1;
  bool no_upload = false;
  std::vector<std::string> sets;
  std::vector<double> times;
  Parser parser{"tool run", "A command for the tests."};

  Command() {
    parser.Positional("DIR", &dir, "a folder")
        .Option("config", &config, "config file", "FILE")
        .Option("port", &port, "port")
        .Option("yaw", &yaw, "yaw rate", "DEG")
        .Option("seed", &seed, "seed")
        .Option("align", &align, "alignment")
        .Choices("align", {"se3", "sim3", "none"})
        .Flag("no-upload", &no_upload, "no upload")
        .Repeated("set", &sets, "override", "K=V")
        .Repeated("time", &times, "a time", "T")
        .Require({"config"})
        .Footer("Exit codes: see the tests.");
  }
  bool Parse(const std::vector<std::string>& args) {
    std::ostringstream help;
    return parser.Parse(args, help);
  }
};

std::string UsageErrorOf(const std::vector<std::string>& args) {
  Command c;
  try {
    c.Parse(args);
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument) << e.what();
    return e.what();
  }
  return "no error";
}

TEST(Cli, ValuesArriveTypedAndDefaultsStay) {
  Command c;
  ASSERT_TRUE(c.Parse({"--config", "c.yaml", "d", "--yaw=-0.5", "--set", "a=1", "--set", "b=2",
                       "--no-upload", "--time", "1.5", "--time", "-2", "--align", "none", "--seed",
                       "18446744073709551615"}));
  EXPECT_EQ(c.dir, "d");
  EXPECT_EQ(c.config, "c.yaml");
  EXPECT_DOUBLE_EQ(c.yaw, -0.5);  // a negative number is a value, not an option
  EXPECT_EQ(c.sets, (std::vector<std::string>{"a=1", "b=2"}));
  EXPECT_EQ(c.times, (std::vector<double>{1.5, -2.0}));
  EXPECT_TRUE(c.no_upload);
  EXPECT_EQ(c.align, "none");
  EXPECT_EQ(c.seed, UINT64_MAX);
  EXPECT_EQ(c.port, 8080);  // not given: the default
  EXPECT_FALSE(c.parser.Given("port"));
  EXPECT_TRUE(c.parser.Given("yaw"));
  Command last;
  ASSERT_TRUE(last.Parse({"--config", "c", "d", "--port", "1", "--port", "2"}));
  EXPECT_EQ(last.port, 2);  // the last of a repeated scalar wins
}

TEST(Cli, EveryUsageErrorNamesTheOption) {
  EXPECT_EQ(UsageErrorOf({"--config", "c", "d", "--bogus"}),
            "unknown option --bogus (see 'tool run --help')");
  EXPECT_EQ(UsageErrorOf({"--config", "c", "d", "--bogus=3"}),
            "unknown option --bogus (see 'tool run --help')");
  // An unknown option is reported before what is missing (the user's typo is the cause).
  EXPECT_EQ(UsageErrorOf({"--bogus", "x"}), "unknown option --bogus (see 'tool run --help')");
  EXPECT_EQ(UsageErrorOf({"--config", "c", "d", "--port", "abc"}),
            "--port: expected an integer, got 'abc' (see 'tool run --help')");
  EXPECT_EQ(UsageErrorOf({"--config", "c", "d", "--port", "99999999999"}),
            "--port: expected an integer, got '99999999999' (see 'tool run --help')");
  EXPECT_EQ(UsageErrorOf({"--config", "c", "d", "--yaw", "nan"}),
            "--yaw: expected a number, got 'nan' (see 'tool run --help')");
  EXPECT_EQ(UsageErrorOf({"--config", "c", "d", "--seed", "-1"}),
            "--seed: expected a non-negative integer, got '-1' (see 'tool run --help')");
  EXPECT_EQ(UsageErrorOf({"--config", "c", "d", "--time", "1", "--time", "x"}),
            "--time: expected a number, got 'x' (see 'tool run --help')");
  EXPECT_EQ(UsageErrorOf({"d", "--config"}), "--config needs a value (see 'tool run --help')");
  EXPECT_EQ(UsageErrorOf({}), "missing DIR, --config (see 'tool run --help')");
  EXPECT_EQ(UsageErrorOf({"--config", "c", "d", "e"}),
            "unexpected argument 'e' (see 'tool run --help')");
  EXPECT_EQ(UsageErrorOf({"--config", "c", "d", "--align", "se4"}),
            "--align: expected se3, sim3, none, got 'se4' (see 'tool run --help')");
  EXPECT_EQ(UsageErrorOf({"--config", "c", "d", "--no-upload=3"}),
            "--no-upload takes no value (see 'tool run --help')");
}

TEST(Cli, HelpGoesToTheGivenStreamAndListsEveryOption) {
  Command c;
  std::ostringstream help;
  EXPECT_FALSE(c.parser.Parse({"--help"}, help));
  for (const char* text : {"A command for the tests.", "DIR", "--config FILE", "(required)",
                           "--port N", "8080", "se3|sim3|none", "--no-upload", "--set K=V",
                           "(repeatable)", "-h,--help", "Exit codes: see the tests."}) {
    EXPECT_NE(help.str().find(text), std::string::npos) << text << " missing in:\n" << help.str();
  }
  Command d;
  std::ostringstream short_help;
  EXPECT_FALSE(d.parser.Parse({"-h"}, short_help));  // --help wins over missing required options
  EXPECT_EQ(short_help.str(), help.str());
}

TEST(Cli, RunMainTurnsErrorsIntoOneLineAndAnExitCode) {
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(RunMain("tool", [] { return kExitOk; }), kExitOk);
  EXPECT_EQ(RunMain("tool", []() -> int { FailUsage("tool run", "missing --out"); }), kExitUsage);
  EXPECT_EQ(RunMain("tool", []() -> int { throw Error(ErrorCode::kParse, "a.pcd: bad header"); }),
            kExitFailure);
  EXPECT_EQ(RunMain("tool", []() -> int { throw std::runtime_error("disk full"); }), kExitFailure);
  EXPECT_EQ(::testing::internal::GetCapturedStderr(),
            "tool: error: missing --out (see 'tool run --help')\n"
            "tool: error: a.pcd: bad header\n"
            "tool: error: disk full\n");
}

}  // namespace
}  // namespace mapdelta::cli
