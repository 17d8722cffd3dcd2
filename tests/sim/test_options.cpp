// CLI parsing: presets set defaults, every override applies, unknown options and bad values
// are errors naming the option, and --help lists every option.
#include <gtest/gtest.h>

#include "mapdelta/common/error.hpp"
#include "mapdelta/sim/options.hpp"

namespace mapdelta::sim {
namespace {

TEST(SimOptions, PresetThenOverrides) {
  const CliArgs a =
      ParseArgs({"--out", "/tmp/x", "--width", "320", "--preset", "paper", "--noise", "big",
                 "--seed", "9", "--sequences", "S1_dark,S2_02", "--shadows", "false"});
  EXPECT_EQ(a.out_dir, "/tmp/x");
  EXPECT_EQ(a.config.width, 320);   // override wins, whatever the order
  EXPECT_EQ(a.config.height, 450);  // paper default kept
  EXPECT_DOUBLE_EQ(a.config.fx, 400.0);
  EXPECT_EQ(a.config.noise, NoiseLevel::kBig);
  EXPECT_EQ(a.config.seed, 9u);
  EXPECT_EQ(a.config.sequences, (std::vector<std::string>{"S1_dark", "S2_02"}));
  EXPECT_FALSE(a.config.shadows);
  const CliArgs t = ParseArgs({"--preset", "tiny", "--out", "d"});
  EXPECT_EQ(t.config.width, 400);
  EXPECT_DOUBLE_EQ(t.config.cy, 112.5);
  EXPECT_EQ(t.config.sequences, (std::vector<std::string>{"S1_01", "S2_01"}));
}

TEST(SimOptions, ErrorsAreCollectedAndNamed) {
  // An unknown option is reported on its own (by common's cli::Parser, as in every program) ...
  try {
    ParseArgs({"--preset", "tiny", "--widht", "3", "--fx", "abc"});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "unknown option --widht (see 'mapdelta-sim --help')");
  }
  // ... bad values of known options all at once, with a missing --out.
  try {
    ParseArgs({"--preset", "tiny", "--width", "3.5", "--fx", "abc", "--noise", "huge"});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("--width: bad value '3.5'"), std::string::npos) << m;
    EXPECT_NE(m.find("--fx: bad value 'abc'"), std::string::npos) << m;
    EXPECT_NE(m.find("--noise: bad value 'huge'"), std::string::npos) << m;
    EXPECT_NE(m.find("missing --out"), std::string::npos) << m;
  }
  EXPECT_THROW(ParseArgs({"--out", "d", "--sequences", "S3_01"}), Error);
  EXPECT_THROW(ParseArgs({"--out", "d", "--length_m", "1000", "--duration_s", "1"}),
               Error);  // 1 km/s
  EXPECT_THROW(ParseArgs({"--out", "d", "--preset", "huge"}), Error);
  EXPECT_TRUE(ParseArgs({"--help"}).help);
}

TEST(SimOptions, HelpListsEveryOption) {
  const std::string help = HelpText();
  for (const char* name :
       {"--preset", "--out", "--seed", "--noise", "--sequences", "--width", "--fx", "--baseline",
        "--cam_rate_hz", "--imu_rate_hz", "--length_m", "--duration_s", "--height_02",
        "--write_depth", "--cloud_leaf", "--threads"}) {
    EXPECT_NE(help.find(name), std::string::npos) << name;
  }
}

}  // namespace
}  // namespace mapdelta::sim
