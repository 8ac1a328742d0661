// The lipmap binary: subcommands classify / map / serve over the same engine (see server/app/cli.h).
#include <sys/auxv.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <utility>
#include <iostream>

#include "server/app/cli.h"

namespace {

// Settings only the environment can make, read before main runs, so the binary sets them and starts
// itself again, once, before anything else runs (a value the user set is kept; if /proc is missing the exec
// fails and the run goes on without them):
// - OpenBLAS (the BLAS under CHOLMOD) starts its thread pool while it is loaded: one thread per core unless
//   OPENBLAS_NUM_THREADS says otherwise. The engine runs BLAS on its own thread (use_single_threaded_solvers,
//   engine/intermediate_map.h), but the pool's idle threads first spin on sched_yield for about 0.1 s: in a
//   `lipmap map` of a 10k-triangle job (0.2 s) a third of the process's CPU time, taken from whatever ran beside it.
// - glibc's malloc asks for transparent huge pages for the big blocks it maps (GLIBC_TUNABLES
//   glibc.malloc.hugetlb=1; the kernel's default policy gives them only when asked). A 250k-triangle job maps
//   about 100 MB afresh (the body's arrays, the engine's, the answer's text), each 4 KiB page a fault of its
//   own otherwise: reading that job's body took 20-39 ms in the service, 13-16 ms with them.
// - Where glibc's malloc takes blocks from and when it gives memory back: blocks up to 32 MiB (its largest
//   mmap threshold) from the heap from the start, and the heap's free top kept up to 1 GiB (the defaults move the
//   threshold as blocks are freed and give back any free top above twice it). A 1M-triangle job frees and
//   allocates its large arrays in turn; given back each time, every new one was fresh pages the kernel zeroed
//   (135 ms of a 2.1 s map). The worker pool gives the memory back once it is idle (server/http/worker_pool.cpp).
//   A value set through glibc's older MALLOC_MMAP_THRESHOLD_ / MALLOC_TRIM_THRESHOLD_ is kept as well.
void start_with_settings(char** argv) {
  // Once only: a process the kernel runs in secure mode (setuid, file capabilities) has GLIBC_TUNABLES
  // cleaned, so the settings could never be seen as made.
  if (std::getenv("LIPMAP_STARTED_AGAIN") != nullptr) {
    unsetenv("LIPMAP_STARTED_AGAIN");
    return;
  }
  if (getauxval(AT_SECURE) != 0) return;
  bool changed = false;
  if (std::getenv("OPENBLAS_NUM_THREADS") == nullptr) changed |= setenv("OPENBLAS_NUM_THREADS", "1", 1) == 0;
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  std::string all = tunables ? tunables : "";
  // Each with the older variable that sets the same (GLIBC_TUNABLES would take precedence over it).
  const std::pair<const char*, const char*> settings[] = {
      {"glibc.malloc.hugetlb=1", nullptr},
      {"glibc.malloc.mmap_threshold=33554432", "MALLOC_MMAP_THRESHOLD_"},
      {"glibc.malloc.trim_threshold=1073741824", "MALLOC_TRIM_THRESHOLD_"}};
  for (const auto& [setting, older] : settings) {
    const std::string name(setting, std::strchr(setting, '=') + 1);  // "glibc.malloc.x="
    const bool named = all.rfind(name, 0) == 0 || all.find(":" + name) != std::string::npos;
    if (named || (older && std::getenv(older) != nullptr)) continue;  // the user's value stands
    all += (all.empty() || all.back() == ':' ? "" : ":") + std::string(setting);
  }
  if (all != (tunables ? tunables : "")) changed |= setenv("GLIBC_TUNABLES", all.c_str(), 1) == 0;
  if (changed && setenv("LIPMAP_STARTED_AGAIN", "1", 1) == 0) execv("/proc/self/exe", argv);
}

}  // namespace

int main(int argc, char** argv) {
  start_with_settings(argv);
  try {
    return lipmap::cli::run(argc, argv, std::cin, std::cout, std::cerr);
  } catch (...) {  // cli::run never throws; this is the last line of defence, not a code path
    std::fputs("lipmap: error: internal_error: unexpected exception\n", stderr);
    return lipmap::codec::kExitInternalError;
  }
}
