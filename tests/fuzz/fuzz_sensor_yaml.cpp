// EuRoC sensor.yaml files (dataset input of the client, VIO and tools): the camera and the IMU
// reader on the same bytes.
#include <cstdint>

#include "mapdelta/common/euroc.hpp"
#include "memory_file.hpp"
#include "parse_errors.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mapdelta;
  const fuzz::MemoryFile file(data, size);
  fuzz::ExpectParseErrorOnly([&] { ReadEurocCameraYaml(file.path()); });
  fuzz::ExpectParseErrorOnly([&] { ReadEurocImuYaml(file.path()); });
  return 0;
}
