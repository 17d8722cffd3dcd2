// libFuzzer target for the PCD and PLY parsers (prior maps arrive over HTTP as PCD/PLY bytes).
// Any input must parse or throw mapdelta::Error; sanitizers catch the rest.
#include <cstddef>
#include <cstdint>
#include <string>

#include "../../../common/src/cloud_readers.hpp"
#include "mapdelta/common/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  for (const bool pcd : {true, false}) {
    try {
      const auto cloud = pcd ? mapdelta::detail::ParsePcd(bytes, "fuzz.pcd")
                             : mapdelta::detail::ParsePly(bytes, "fuzz.ply");
      (void)cloud;
    } catch (const mapdelta::Error&) {
    }
  }
  return 0;
}
