// The server's stored tile blobs (blob_codec: magic, kind, version, size, CRC-32, zlib). They
// come from our own database, but a damaged file or a blob from a newer binary must be refused
// with a named error, never read past its end or sized from an unchecked header. The first
// byte picks the decoder (points, aggregate, changes, session octree, coverage bits); the rest
// is the blob.
#include <cstdint>

#include "blob_codec.hpp"
#include "mapdelta/common/error.hpp"
#include "mapdelta/common/observed_area.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mapdelta;
  if (size == 0) return 0;
  const server::Bytes blob(data + 1, data + size);
  try {
    switch (data[0] % 5) {
      case 0:
        server::DecodePoints(blob);
        break;
      case 1:
        server::DecodeAggregate(blob);
        break;
      case 2:
        server::DecodeChanges(blob);
        break;
      case 3:  // as the tile classifier reads a session's octree (also a legacy bare stream)
        ObservedArea::DeserializeBinary(server::DecodeObserved(blob));
        break;
      case 4:
        server::DecodePointBits(blob);
        break;
    }
  } catch (const Error& e) {
    if (e.code() != ErrorCode::kParse && e.code() != ErrorCode::kUnsupported) throw;
  }
  return 0;
}
