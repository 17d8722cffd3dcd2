// Keyframe upload, part 'depth': the PNG bytes through MapService::PutKeyframe (IHDR checked
// against the session camera before decoding, then OpenCV's decoder, then the keyframe cloud)
// beside a valid meta. Bad input must get a 4xx error, nothing else.
#include <cstdint>

#include "client_errors.hpp"
#include "service_fixture.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mapdelta;
  auto& fixture = fuzz::ServiceFixture::Get();
  static const server::Json meta{{"t_ns", 1000},
                                 {"T_map_cam", {{"t", {0, 0, 1.5}}, {"q", {1, 0, 0, 0}}}}};
  fuzz::ExpectClientErrorOnly([&] {
    bool created = false;
    fixture.service().PutKeyframe(fixture.session_id(), 0, meta, server::Bytes(data, data + size),
                                  &created);
  });
  return 0;
}
