// Readers of outside files refuse values their integer arithmetic cannot hold, found by the
// fuzz targets (tests/fuzz/regressions/).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/trajectory_io.hpp"

namespace mapdelta {
namespace {

TEST(TrajectoryIo, StampsBeyondInt64NanosecondsAreALineError) {
  const auto path =
      std::filesystem::temp_directory_path() / ("md_tum_" + std::to_string(getpid()) + ".txt");
  const std::string pose = " 0 0 0 0 0 0 1\n";
  std::ofstream(path) << "1311868164.363181" << pose << "9311868164.399026" << pose;
  try {
    ReadTumTrajectory(path.string());
    FAIL() << "a stamp of 9.3e9 s was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kParse);
    EXPECT_NE(std::string(e.what()).find(":2: time stamp beyond"), std::string::npos) << e.what();
  }
  std::ofstream(path) << "1311868164.363181" << pose << "9199999999.5" << pose;
  EXPECT_EQ(ReadTumTrajectory(path.string()).back().t_ns, 9199999999500000000LL);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace mapdelta
