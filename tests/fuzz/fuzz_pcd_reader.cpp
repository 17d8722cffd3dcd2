// PCD files (prior import over POST /v1/admin/prior and import-prior): our bounds-checked
// parser, the one ReadCloud uses (ascii, binary, binary_compressed).
#include <cstdint>
#include <string_view>

#include "cloud_readers.hpp"
#include "parse_errors.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mapdelta;
  fuzz::ExpectParseErrorOnly([&] {
    detail::ParsePcd(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.pcd");
  });
  return 0;
}
