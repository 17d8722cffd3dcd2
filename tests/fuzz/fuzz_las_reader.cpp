// LAS 1.0-1.4 files (prior import: import-prior, and the tools' ReadCloud): our own header and
// point parser (common/src/las_io.cpp). A file that parses is encoded again and read back, so a
// header the reader accepted in a state the writer cannot reproduce shows here.
#include <cstdint>
#include <string_view>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/las_io.hpp"
#include "parse_errors.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mapdelta;
  try {
    fuzz::ExpectParseErrorOnly([&] {
      const PointCloud cloud =
          ParseLas(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.las");
      // EncodeLas refuses (kInvalidArgument) what it cannot hold: non-finite points, extents
      // beyond int32 at its scale.
      if (ParseLas(EncodeLas(cloud), "again.las").size() != cloud.size())
        throw Error(ErrorCode::kInternal, "LAS round trip changed the point count");
    });
  } catch (const Error& e) {
    // LAZ and versions other than 1.x are named as unsupported: an expected answer too.
    if (e.code() != ErrorCode::kUnsupported) throw;
  }
  return 0;
}
