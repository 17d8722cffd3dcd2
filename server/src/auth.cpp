#include "auth.hpp"

#include <openssl/evp.h>
#include <openssl/rand.h>

#include "mapdelta/common/error.hpp"

namespace mapdelta::server {
namespace {
std::string Hex(const unsigned char* p, size_t n) {
  static const char* kDigits = "0123456789abcdef";
  std::string out(2 * n, '0');
  for (size_t i = 0; i < n; ++i) {
    out[2 * i] = kDigits[p[i] >> 4];
    out[2 * i + 1] = kDigits[p[i] & 15];
  }
  return out;
}
}  // namespace

std::string Sha256Hex(std::string_view data) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (EVP_Digest(data.data(), data.size(), digest, &length, EVP_sha256(), nullptr) != 1) {
    throw Error(ErrorCode::kInternal, "SHA-256 failed");
  }
  return Hex(digest, length);
}

std::string RandomHex(size_t bytes) {
  std::string buf(bytes, '\0');
  if (RAND_bytes(reinterpret_cast<unsigned char*>(buf.data()), static_cast<int>(bytes)) != 1) {
    throw Error(ErrorCode::kInternal, "no randomness available for tokens");
  }
  return Hex(reinterpret_cast<const unsigned char*>(buf.data()), bytes);
}

CreatedToken CreateToken(Storage& storage, const std::string& name, Role role, int64_t now_ms) {
  if (name.empty() || name.size() > 200) {
    throw Error(ErrorCode::kInvalidArgument, "token name must have 1..200 characters");
  }
  CreatedToken t;
  t.record.id = RandomHex(6);
  t.record.name = name;
  t.record.role = role;
  t.record.created_ms = now_ms;
  t.secret = "mdt_" + t.record.id + "_" + RandomHex(16);
  storage.tokens().Insert(t.record, Sha256Hex(t.secret));
  return t;
}

std::optional<TokenRecord> Authenticate(Storage& storage, std::string_view header) {
  constexpr std::string_view kPrefix = "Bearer ";
  if (header.size() <= kPrefix.size() || header.substr(0, kPrefix.size()) != kPrefix) {
    return std::nullopt;
  }
  const std::string_view secret = header.substr(kPrefix.size());
  if (secret.size() > 256) return std::nullopt;
  return storage.tokens().FindActiveByHash(Sha256Hex(secret));
}

bool RoleAllows(Role have, std::initializer_list<Role> allowed) {
  if (have == Role::kAdmin) return true;
  for (Role r : allowed) {
    if (r == have) return true;
  }
  return false;
}

}  // namespace mapdelta::server
