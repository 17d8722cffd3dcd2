// The other request inputs MapService parses itself. The first byte picks the decoder, the
// rest is its text: 0 = session body (JSON), 1 = admin job body (JSON), 2 = the changed-tiles
// bbox "x0,y0,x1,y1", 3 = a tile id in a path ("3_-2"). Bad input must get a 4xx error and
// nothing else.
#include <cstdint>
#include <string>
#include <string_view>

#include "api_json.hpp"
#include "client_errors.hpp"
#include "service_fixture.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mapdelta;
  if (size == 0) return 0;
  auto& service = fuzz::ServiceFixture::Get().service();
  const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);
  fuzz::ExpectClientErrorOnly([&] {
    switch (data[0] % 4) {
      case 0:
        service.CreateSession(server::ParseApiJson(text, "body"));
        break;
      case 1:
        service.CreateJob(server::ParseApiJson(text, "body"));
        break;
      case 2:
        service.ListChangedTiles(std::string(text), 0.0, 1, 100);
        break;
      case 3:
        service.GetTileChanges(std::string(text), "json", "", 0.0, 0);
        break;
    }
  });
  return 0;
}
