// libFuzzer target for ObservedArea::DeserializeBinary (observed octrees are exchanged as .bt
// bytes). Any input must load or throw mapdelta::Error.
#include <cstddef>
#include <cstdint>
#include <string>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/observed_area.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const auto area = mapdelta::ObservedArea::DeserializeBinary(
        std::string(reinterpret_cast<const char*>(data), size));
    (void)area.NumKnownLeaves();
  } catch (const mapdelta::Error&) {
  }
  return 0;
}
