// Keyframe upload, part 'meta': the JSON text as the HTTP handler parses it (ParseApiJson,
// depth-capped) and then validated by MapService::PutKeyframe beside a valid 16-bit PNG.
// Bad input must get a 4xx error, nothing else.
#include <cstdint>
#include <string_view>

#include "api_json.hpp"
#include "client_errors.hpp"
#include "mapdelta/common/depth_image.hpp"
#include "service_fixture.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mapdelta;
  auto& fixture = fuzz::ServiceFixture::Get();
  static const server::Bytes png = [] {
    DepthImage depth(fuzz::ServiceFixture::kWidth, fuzz::ServiceFixture::kHeight);
    depth.at(10, 10) = 4.0f;
    const auto bytes = EncodeDepthPng(depth);
    return server::Bytes(bytes.begin(), bytes.end());
  }();
  fuzz::ExpectClientErrorOnly([&] {
    const server::Json meta = server::ParseApiJson(
        std::string_view(reinterpret_cast<const char*>(data), size), "part 'meta'");
    bool created = false;
    fixture.service().PutKeyframe(fixture.session_id(), 0, meta, png, &created);
  });
  return 0;
}
