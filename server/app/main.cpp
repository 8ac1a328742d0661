// The lipmap binary: subcommands classify / map / serve over the same engine (see server/app/cli.h).
#include <cstdio>
#include <iostream>

#include "server/app/cli.h"

int main(int argc, char** argv) {
  try {
    return lipmap::cli::run(argc, argv, std::cin, std::cout, std::cerr);
  } catch (...) {  // cli::run never throws; this is the last line of defence, not a code path
    std::fputs("lipmap: error: internal_error: unexpected exception\n", stderr);
    return lipmap::codec::kExitInternalError;
  }
}
