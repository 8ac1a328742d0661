// Where the shared test data lives: $LIPMAP_DATA_DIR, else ../shared/data beside the source tree (set by
// tests/CMakeLists.txt).
#pragma once

#include <cstdlib>
#include <string>

namespace lipmap {

inline std::string data_dir() {
  if (const char* env = std::getenv("LIPMAP_DATA_DIR"); env && *env) return env;
  return LIPMAP_DATA_DIR;
}

}  // namespace lipmap
