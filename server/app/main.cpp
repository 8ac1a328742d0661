// The lipmap binary: subcommands classify / map / serve over the same engine (see server/app/cli.h).
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>

#include "server/app/cli.h"

namespace {

// OpenBLAS (the BLAS under CHOLMOD) starts its thread pool while it is loaded, before main: one thread per core
// unless OPENBLAS_NUM_THREADS says otherwise. The engine then runs BLAS on its own thread
// (use_single_threaded_solvers, engine/intermediate_map.h), but the pool's idle threads first spin on sched_yield
// for about 0.1 s. In a `lipmap map` of a 10k-triangle job (0.2 s) that was a third of the process's CPU time,
// taken from whatever ran beside it. So the binary sets the variable and starts itself again, once, before
// anything else runs; a value the user set is kept. If /proc is missing the exec fails and the run goes on.
void start_with_one_blas_thread(char** argv) {
  if (std::getenv("OPENBLAS_NUM_THREADS") != nullptr) return;
  if (setenv("OPENBLAS_NUM_THREADS", "1", 1) != 0) return;
  execv("/proc/self/exe", argv);
}

}  // namespace

int main(int argc, char** argv) {
  start_with_one_blas_thread(argv);
  try {
    return lipmap::cli::run(argc, argv, std::cin, std::cout, std::cerr);
  } catch (...) {  // cli::run never throws; this is the last line of defence, not a code path
    std::fputs("lipmap: error: internal_error: unexpected exception\n", stderr);
    return lipmap::codec::kExitInternalError;
  }
}
