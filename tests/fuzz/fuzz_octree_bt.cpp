// OctoMap .bt and .ot bytes (observed areas: .ot stored per session, .bt served per tile and
// read by the tools): ObservedArea::DeserializeBinary validates the stream before OctoMap parses
// it. An octree that loads is then queried and written back in both formats, so a tree
// accepted in a broken state shows here.
#include <cstdint>
#include <string>

#include "mapdelta/common/observed_area.hpp"
#include "parse_errors.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mapdelta;
  fuzz::ExpectParseErrorOnly([&] {
    const ObservedArea area =
        ObservedArea::DeserializeBinary(std::string(reinterpret_cast<const char*>(data), size));
    area.NumKnownLeaves();
    // Writing may prune (same answers, fewer leaves), so compare answers, not leaf counts.
    const ObservedArea again = ObservedArea::DeserializeBinary(area.SerializeBinary());
    const ObservedArea full = ObservedArea::DeserializeBinary(area.SerializeEvidence());
    for (const Point& p :
         {Point(0.5f, 0.5f, 0.5f), Point(-3.f, 2.f, 1.f), Point(10.f, -7.f, 0.f)}) {
      if (again.IsObserved(p) != area.IsObserved(p) ||
          full.IsSeenFree(p, 2) != area.IsSeenFree(p, 2))
        throw Error(ErrorCode::kInternal, "round trip changed the tree");
    }
  });
  return 0;
}
