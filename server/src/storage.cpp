#include "mapdelta/server/storage.hpp"

#include "mapdelta/common/error.hpp"

namespace mapdelta::server {

Storage::Storage(Stores stores) : stores_(std::move(stores)) {
  if (!stores_.tokens || !stores_.priors || !stores_.sessions || !stores_.jobs || !stores_.tiles ||
      !stores_.clusters || !stores_.coverage) {
    throw Error(ErrorCode::kInternal, "Storage: a backend left one of its seven stores out");
  }
}

}  // namespace mapdelta::server
