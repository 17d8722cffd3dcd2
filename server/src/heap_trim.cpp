#include "heap_trim.hpp"

#ifdef __GLIBC__
#include <malloc.h>
#endif

namespace mapdelta::server {

bool ReturnFreedHeapToSystem() {
#ifdef __GLIBC__
  malloc_trim(0);
  return true;
#else
  return false;
#endif
}

}  // namespace mapdelta::server
