// The one strict YAML config reader (common/config_reader.hpp): unknown keys are errors, all
// problems come at once with file and key, and the echo reads back to the same values.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "mapdelta/common/config_reader.hpp"
#include "mapdelta/common/error.hpp"
#include "support/temp_dir.hpp"

namespace mapdelta {
namespace {

struct Demo {
  struct Net {
    std::string address = "127.0.0.1";
    int port = 8080;  // 0 = any
    int64_t max_bytes = 1 << 20;
  } net;
  struct Filter {
    double delta_m = 0.5;
    int window = 5;  // odd
    bool enabled = true;
    std::string mode = "fast";
  } filter;
};

ConfigSchema Schema(Demo& d) {
  ConfigSchema s;
  s.Field("net.address", &d.net.address)
      .Field("net.port", &d.net.port, 0, 65535)
      .Field("net.max_bytes", &d.net.max_bytes, 1024, INT64_MAX)
      .Field("filter.delta_m", &d.filter.delta_m, 1e-6, 10)
      .Field("filter.window", &d.filter.window, 1, 31)
      .Field("filter.enabled", &d.filter.enabled)
      .Field("filter.mode", &d.filter.mode, {"fast", "exact"})
      .Rule([&d] { return d.filter.window % 2 == 0 ? "filter.window: must be odd" : ""; });
  return s;
}

std::string ProblemsOf(const std::string& text) {
  Demo d;
  try {
    ReadConfigYaml(text, "demo.yaml", Schema(d));
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    return e.what();
  }
  return "no error";
}

TEST(ConfigReader, ReadsKnownKeysAndKeepsDefaults) {
  Demo d;
  ReadConfigYaml("net:\n  port: 9000\nfilter:\n  enabled: false\n  mode: exact\n", "x", Schema(d));
  EXPECT_EQ(d.net.port, 9000);
  EXPECT_FALSE(d.filter.enabled);
  EXPECT_EQ(d.filter.mode, "exact");
  EXPECT_EQ(d.net.address, "127.0.0.1");
  EXPECT_DOUBLE_EQ(d.filter.delta_m, 0.5);
  Demo empty;
  EXPECT_NO_THROW(ReadConfigYaml("", "empty", Schema(empty)));
  EXPECT_NO_THROW(ReadConfigYaml("net:\n", "section without keys", Schema(empty)));
  EXPECT_EQ(empty.net.port, 8080);
}

TEST(ConfigReader, ReportsEveryProblemAtOnceWithItsKey) {
  const std::string m = ProblemsOf(
      "net:\n  prot: 1\n  port: many\n  max_bytes: 10\n"
      "filter:\n  window: 4\n  mode: slow\n  delta_m: [1, 2]\n  enabled: perhaps\n"
      "extra:\n  a: 1\n");
  EXPECT_NE(m.find("demo.yaml: 8 problem(s):"), std::string::npos) << m;
  for (const char* line :
       {"  - net.prot: unknown key", "  - net.port: expected an integer, got 'many'",
        "  - net.max_bytes: 10 is outside [1024, 9.22337203685e+18]",
        "  - filter.mode: expected one of fast, exact, got 'slow'",
        "  - filter.delta_m: expected a number, got a non-scalar",
        "  - filter.enabled: expected true or false, got 'perhaps'", "  - extra: unknown section",
        "  - filter.window: must be odd"}) {
    EXPECT_NE(m.find(line), std::string::npos) << line << " missing in:\n" << m;
  }
  EXPECT_NE(ProblemsOf("net: 3\n").find("net: expected a mapping of keys"), std::string::npos);
  EXPECT_NE(ProblemsOf("[1, 2]\n").find("demo.yaml: expected a mapping of sections"),
            std::string::npos);
  EXPECT_NE(ProblemsOf("net: {port: 1\n").find("demo.yaml: not valid YAML"), std::string::npos);
  EXPECT_NE(ProblemsOf("net:\n  port: 70000\n").find("net.port: 70000 is outside [0, 65535]"),
            std::string::npos);
  EXPECT_NE(ProblemsOf("net:\n  address: ''\n").find("net.address: must not be empty"),
            std::string::npos);
}

TEST(ConfigReader, FilesAndTheEchoRoundTrip) {
  const auto dir = testing::FreshTempDir("config_reader");
  Demo d;
  d.net.address = "host: with colon";  // needs quoting in YAML
  d.filter.delta_m = 0.123456789;
  d.net.max_bytes = int64_t{1} << 40;
  d.filter.enabled = false;
  const std::string yaml = ConfigToYaml(Schema(d));
  std::ofstream(dir / "echo.yaml") << yaml;
  Demo back;
  ReadConfigFile((dir / "echo.yaml").string(), Schema(back));
  EXPECT_EQ(back.net.address, d.net.address);
  EXPECT_DOUBLE_EQ(back.filter.delta_m, d.filter.delta_m);
  EXPECT_EQ(back.net.max_bytes, d.net.max_bytes);
  EXPECT_FALSE(back.filter.enabled);
  EXPECT_EQ(ConfigToYaml(Schema(back)), yaml);
  EXPECT_NE(yaml.find("net:\n  address:"), std::string::npos) << yaml;
  try {
    ReadConfigFile((dir / "missing.yaml").string(), Schema(back));
    FAIL() << "a missing file was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);  // a config error: exit code 2
    EXPECT_NE(std::string(e.what()).find("missing.yaml: cannot read config file"),
              std::string::npos);
  }
  Demo bad;
  bad.filter.window = 2;
  EXPECT_THROW(ThrowIfInvalid(Schema(bad), "config"), Error);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mapdelta
