#pragma once
// Bearer tokens: only a hash of the secret is stored.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "mapdelta/server/states.hpp"

namespace mapdelta::server {

struct TokenRecord {
  std::string id, name;
  Role role = Role::kReader;
  int64_t created_ms = 0;
  std::optional<int64_t> revoked_ms;
};

class TokenStore {
 public:
  virtual ~TokenStore() = default;
  // Throws Error(kConflict) if the id or the hash is taken.
  virtual void Insert(const TokenRecord& token, const std::string& hash) = 0;
  virtual std::optional<TokenRecord> FindActiveByHash(const std::string& hash) = 0;
  // False if there is no such token or it is revoked already.
  virtual bool Revoke(const std::string& id, int64_t now_ms) = 0;
  virtual std::vector<TokenRecord> List() = 0;  // by created_ms
};

}  // namespace mapdelta::server
