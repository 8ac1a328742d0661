#include "tests/support/data_dir.h"

#include <cstdlib>

namespace lipmap {

std::string data_dir() {
  if (const char* env = std::getenv("LIPMAP_DATA_DIR"); env && *env) return env;
  return LIPMAP_DATA_DIR;
}

std::string source_dir() { return LIPMAP_SOURCE_DIR; }

}  // namespace lipmap
