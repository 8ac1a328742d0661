// Where the test data lives: the repository's tests/data (tests/support/data_dir.cpp), or $LIPMAP_DATA_DIR.
// The paths are compiled into one small translation unit only, so that the other test sources do not depend
// on where the checkout is (ccache hits across worktrees and clones).
#pragma once

#include <string>

namespace lipmap {

// $LIPMAP_DATA_DIR when set, else <source>/tests/data.
std::string data_dir();

// The repository's root (the folder with CMakeLists.txt, proto/, tests/).
std::string source_dir();

}  // namespace lipmap
