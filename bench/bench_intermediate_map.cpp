// Benchmark of the intermediate-map stage (paper 4, 5.1) on the test disk meshes (tests/data/meshes): median over 5 runs of
// the factorization and the two-column solve, for tutte and harmonic, plus assembly, the exact flip check
// and the whole stage.
//
//   bench_intermediate_map [DATA_DIR] [RUNS]      (DATA_DIR defaults to $LIPMAP_DATA_DIR or the repository's tests/data)
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <sys/utsname.h>

#include "engine/error.h"
#include "engine/intermediate_map.h"
#include "engine/mesh_io.h"
#include "engine/validate.h"
#include "tests/support/test_meshes.h"

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      return colon == std::string::npos ? line : line.substr(colon + 2);
    }
  return "unknown";
}

}  // namespace

int main(int argc, char** argv) {
  std::string data = argc > 1 ? argv[1] : "";
  if (data.empty()) {
    const char* env = std::getenv("LIPMAP_DATA_DIR");
    data = env && *env ? env : LIPMAP_DATA_DIR;
  }
  const int runs = argc > 2 ? std::max(1, std::atoi(argv[2])) : 5;

  utsname u{};
  uname(&u);
  std::printf("# intermediate maps: median of %d runs, times in ms\n", runs);
  std::printf("# machine: %s %s %s %s; nproc %u; cpu %s\n", u.sysname, u.release, u.version, u.machine,
              std::thread::hardware_concurrency(), cpu_model().c_str());
  {
    std::ifstream load("/proc/loadavg");
    std::string l1, l5, l15;
    load >> l1 >> l5 >> l15;
    std::printf("# load average at start: %s %s %s (timings are only comparable on an idle machine)\n", l1.c_str(),
                l5.c_str(), l15.c_str());
  }
  std::printf("# factor = CHOLMOD supernodal LLT of L_II; solve = one 2-column solve; check = exact orientation of\n"
              "# every triangle; total = whole stage incl. assembly and any fallback\n");
  std::printf("%-30s %7s %7s %5s | %-8s %8s %8s %8s %8s %8s %6s %5s\n", "mesh", "V", "F", "nb", "method", "assemble",
              "factor", "solve", "check", "total", "flips0", "sol");

  int failures = 0;
  // Every disk mesh of the tests' catalog (tests/support/test_meshes.h), with $LIPMAP_EXTRA_MESHES.
  for (const lipmap::testmeshes::MeshEntry& entry : lipmap::testmeshes::disk_meshes()) {
    const std::string file = entry.extra ? entry.file : data + "/meshes/" + entry.file;
    const char* name = entry.file.c_str();
    lipmap::DiskMesh disk;
    try {
      disk = lipmap::validate_mesh(lipmap::read_mesh_file(file));
    } catch (const std::exception& e) {
      std::printf("%-30s skipped: %s\n", name, e.what());
      continue;
    }
    const lipmap::DiskMapInput in{&disk.vertices, &disk.faces, &disk.boundary_loop};
    for (lipmap::MapMethod method : {lipmap::MapMethod::tutte, lipmap::MapMethod::harmonic}) {
      std::vector<double> assemble, factor, solve, check, total;
      lipmap::DiskMap last;
      lipmap::map_to_disk(in, method);  // warm-up (first CHOLMOD/BLAS use, page faults)
      for (int r = 0; r < runs; ++r) {
        last = lipmap::map_to_disk(in, method);
        assemble.push_back(last.assemble_ms);
        factor.push_back(last.factor_ms);
        solve.push_back(last.solve_ms);
        check.push_back(last.check_ms);
        total.push_back(last.total_ms);
      }
      if (!last.bijective()) ++failures;
      std::printf("%-30s %7zu %7zu %5zu | %-8s %8.2f %8.2f %8.2f %8.2f %8.2f %6d %5s%s\n", name, disk.vertices.size(),
                  disk.faces.size(), disk.boundary_loop.size(), lipmap::to_string(method), median(assemble),
                  median(factor), median(solve), median(check), median(total), last.flipped_after_solve,
                  lipmap::to_string(last.solution), last.bijective() ? "" : "  NOT BIJECTIVE");
      std::fflush(stdout);
    }
  }
  return failures == 0 ? 0 : 1;
}
