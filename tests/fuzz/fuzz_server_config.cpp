// The server's YAML config (LoadServerConfig: unknown keys and types reported at once, then
// ValidateServerConfig's ranges), and the effective config echoed back for a config that loads.
#include <cstdint>

#include "mapdelta/server/config.hpp"
#include "memory_file.hpp"
#include "parse_errors.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mapdelta;
  const fuzz::MemoryFile file(data, size);
  fuzz::ExpectParseErrorOnly([&] {
    const server::ServerConfig config = server::LoadServerConfig(file.path());
    server::ValidateServerConfig(config);
    server::DumpServerConfig(config);
  });
  return 0;
}
