#pragma once
// Bearer tokens: "mdt_<id>_<secret>", 128-bit random secret, stored as SHA-256 hex only.
#include <optional>
#include <string>

#include "mapdelta/server/storage.hpp"

namespace mapdelta::server {

std::string Sha256Hex(std::string_view data);
std::string RandomHex(size_t bytes);  // from the OS CSPRNG (OpenSSL RAND_bytes)

struct CreatedToken {
  TokenRecord record;
  std::string secret;  // shown once, never stored
};

CreatedToken CreateToken(Storage& storage, const std::string& name, Role role, int64_t now_ms);
// The token record for an "Authorization" header value, or nullopt (-> 401).
std::optional<TokenRecord> Authenticate(Storage& storage, std::string_view authorization_header);
// admin may do everything; otherwise the role must be in the allowed set.
bool RoleAllows(Role have, std::initializer_list<Role> allowed);

}  // namespace mapdelta::server
