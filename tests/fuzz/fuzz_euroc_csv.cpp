// Text tables of datasets and trajectories: EuRoC image lists and IMU CSV, EuRoC ground
// truth, TUM trajectories (all client/tool input). Every reader gets the same bytes.
#include <cstdint>

#include "mapdelta/common/euroc.hpp"
#include "mapdelta/common/trajectory_io.hpp"
#include "memory_file.hpp"
#include "parse_errors.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mapdelta;
  const fuzz::MemoryFile file(data, size);
  fuzz::ExpectParseErrorOnly([&] { ReadEurocImageList(file.path(), "data"); });
  fuzz::ExpectParseErrorOnly([&] { ReadEurocImuCsv(file.path()); });
  fuzz::ExpectParseErrorOnly([&] { ReadEurocTrajectory(file.path()); });
  fuzz::ExpectParseErrorOnly([&] { ReadTumTrajectory(file.path()); });
  return 0;
}
