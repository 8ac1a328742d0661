// The fill-reducing ordering of the intermediate maps' factorization (engine/intermediate_map.cpp: CHOLMOD
// supernodal LLT of the interior block of the cotangent Laplacian), measured on one shared mesh and its 1-to-4
// subdivisions (bench/subdivide.h): for each of CHOLMOD's orderings (its default choice, AMD, METIS, CHOLMOD's
// nested dissection), the time of analyze (ordering + symbolic), factorize, one two-column solve, the
// factor's nonzeros and the residual of the solve. Single-threaded BLAS, as in the engine. Beside them the
// engine's other solver of these systems, multigrid-preconditioned conjugate gradients (engine/multigrid.h;
// "analyze" is its set-up, "nnz(L)" the nonzeros of all its levels' operators), and per size a
// summary line: CHOLMOD's default (what the engine factors with) against multigrid, set-up plus solve, and how
// far apart their answers are.
//
//   bench_ordering [--levels N (default 2)] [--mesh NAME (default max_registration_partial)] [--runs R (1)]
//                  [--default-only (CHOLMOD's default choice and multigrid, no other orderings)]

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <Eigen/CholmodSupport>
#include <Eigen/Sparse>

#include "engine/multigrid.h"
#include "engine/intermediate_map.h"
#include "engine/mesh_io.h"
#include "engine/mesh_topology.h"
#include "subdivide.h"
#include "tests/support/test_meshes.h"

namespace {

using Clock = std::chrono::steady_clock;
using SpMat = Eigen::SparseMatrix<double>;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

struct Ordering {
  const char* name;
  int method;  // -1: CHOLMOD's default choice (nmethods = 0)
};

}  // namespace

int main(int argc, char** argv) {
  int levels = 2, runs = 1;
  bool default_only = false;
  std::string name = "max_registration_partial";
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--levels") && i + 1 < argc) levels = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--mesh") && i + 1 < argc) name = argv[++i];
    else if (!std::strcmp(argv[i], "--runs") && i + 1 < argc) runs = std::max(1, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--default-only")) default_only = true;
  }
  lipmap::use_single_threaded_solvers();
  std::vector<lipmap::Point3> vertices;
  std::vector<lipmap::Triangle> faces;
  for (const auto& entry : lipmap::testmeshes::disk_meshes())
    if (entry.name() == name) {
      const lipmap::RawMesh raw = lipmap::read_mesh_file(entry.path());
      vertices = raw.vertices;
      for (const auto& f : raw.faces) faces.push_back({int(f[0]), int(f[1]), int(f[2])});
    }
  if (faces.empty()) {
    std::printf("no disk mesh named %s\n", name.c_str());
    return 0;
  }
  std::printf("# CHOLMOD orderings for the interior cotangent Laplacian; times in ms (best of %d)\n", runs);
  std::printf("%-9s %8s %8s %-9s %9s %9s %8s %11s %9s %6s\n", "triangles", "rows", "nnz(A)", "ordering", "analyze",
              "factor", "solve", "nnz(L)", "residual", "cycles");
  std::vector<std::string> summaries;
  std::vector<double> cholmod_ms, multigrid_ms;
  std::vector<std::size_t> sizes;
  const Ordering orderings[] = {{"default", -1}, {"AMD", CHOLMOD_AMD}, {"METIS", CHOLMOD_METIS}, {"NESDIS", CHOLMOD_NESDIS}};
  for (int level = 0; level <= levels; ++level) {
    if (level > 0) lipmap::bench::subdivide(vertices, faces);
    const lipmap::MeshTopology topo(static_cast<int>(vertices.size()), faces);
    const std::vector<int>& loop = topo.boundary_loops().front();
    // Rows of the interior system: interior vertices in vertex order; boundary vertices -1, their values
    // (x and y of the 3D position, any boundary data serves to time the solve) on the right-hand side.
    std::vector<int> row(vertices.size(), 0);
    int m = 0;
    std::vector<char> boundary(vertices.size(), 0);
    for (int v : loop) boundary[v] = 1;
    for (std::size_t v = 0; v < vertices.size(); ++v) row[v] = boundary[v] ? -1 : m++;
    const SpMat L = lipmap::cotan_laplacian(vertices, faces);
    std::vector<Eigen::Triplet<double>> trip;
    Eigen::MatrixXd b = Eigen::MatrixXd::Zero(m, 2);
    for (int k = 0; k < L.outerSize(); ++k)
      for (SpMat::InnerIterator it(L, k); it; ++it) {
        const int i = row[it.row()], j = row[it.col()];
        if (i >= 0 && j >= 0) trip.emplace_back(i, j, it.value());
        else if (i >= 0) {
          const lipmap::Point3& p = vertices[it.col()];
          b(i, 0) -= it.value() * p.x;
          b(i, 1) -= it.value() * p.y;
        }
      }
    SpMat A(m, m);
    A.setFromTriplets(trip.begin(), trip.end());
    A.makeCompressed();
    double default_total = 0;
    Eigen::MatrixXd default_x;
    for (const Ordering& o : orderings) {
      if (default_only && o.method >= 0) continue;
      double best_analyze = 1e300, best_factor = 1e300, best_solve = 1e300, residual = 0;
      long long lnz = 0;
      for (int r = 0; r < runs; ++r) {
        Eigen::CholmodSupernodalLLT<SpMat, Eigen::Lower> llt;
        llt.cholmod().print = 0;
        if (o.method >= 0) {
          llt.cholmod().nmethods = 1;
          llt.cholmod().method[0].ordering = o.method;
          llt.cholmod().postorder = 1;
        }
        auto t0 = Clock::now();
        llt.analyzePattern(A);
        best_analyze = std::min(best_analyze, ms_since(t0));
        t0 = Clock::now();
        llt.factorize(A);
        best_factor = std::min(best_factor, ms_since(t0));
        t0 = Clock::now();
        const Eigen::MatrixXd x = llt.solve(b);
        best_solve = std::min(best_solve, ms_since(t0));
        if (o.method < 0) default_x = x;
        residual = (A * x - b).norm() / std::max(1e-300, b.norm());
        lnz = static_cast<long long>(llt.cholmod().lnz);
      }
      std::printf("%-9zu %8d %8ld %-9s %9.1f %9.1f %8.1f %11lld %9.1e %6s\n", faces.size(), m,
                  static_cast<long>(A.nonZeros()), o.name, best_analyze, best_factor, best_solve, lnz, residual, "-");
      std::fflush(stdout);
      if (o.method < 0) default_total = best_analyze + best_factor + best_solve;
    }
    double best_setup = 1e300, best_solve = 1e300, residual = 0, difference = 0;
    lipmap::MultigridStats stats;
    for (int r = 0; r < runs; ++r) {
      lipmap::AggregationMultigrid multigrid;
      auto t0 = Clock::now();
      if (!multigrid.compute(A)) {
        std::printf("multigrid: set-up failed\n");
        return 1;
      }
      best_setup = std::min(best_setup, ms_since(t0));
      t0 = Clock::now();
      const Eigen::MatrixXd x = multigrid.solve(b);
      best_solve = std::min(best_solve, ms_since(t0));
      residual = (A * x - b).norm() / std::max(1e-300, b.norm());
      difference = (x - default_x).cwiseAbs().maxCoeff() / std::max(1e-300, default_x.cwiseAbs().maxCoeff());
      stats = multigrid.stats();
    }
    std::printf("%-9zu %8d %8ld %-9s %9.1f %9s %8.1f %11lld %9.1e %6d\n", faces.size(), m,
                static_cast<long>(A.nonZeros()), "multigrid", best_setup, "-", best_solve, stats.operator_nonzeros,
                residual, stats.iterations);
    std::fflush(stdout);
    char line[512];
    std::snprintf(line, sizeof line,
                  "summary: %zu triangles (%d rows): CHOLMOD default %.1f ms, multigrid %.1f ms (%d levels, "
                  "%d cycles), multigrid / CHOLMOD %.2f, max |x_multigrid - x_CHOLMOD| / max |x_CHOLMOD| %.1e",
                  faces.size(), m, default_total, best_setup + best_solve, stats.levels, stats.iterations,
                  (best_setup + best_solve) / default_total, difference);
    summaries.push_back(line);
    cholmod_ms.push_back(default_total);
    multigrid_ms.push_back(best_setup + best_solve);
    sizes.push_back(faces.size());
  }
  for (const std::string& line : summaries) std::printf("%s\n", line.c_str());
  if (sizes.size() >= 2) {  // the growth of each solver between the two largest sizes
    const std::size_t k = sizes.size() - 1;
    std::printf("summary: growth %zu -> %zu triangles (%.2fx): CHOLMOD default %.2fx, multigrid %.2fx\n",
                sizes[k - 1], sizes[k], double(sizes[k]) / double(sizes[k - 1]), cholmod_ms[k] / cholmod_ms[k - 1],
                multigrid_ms[k] / multigrid_ms[k - 1]);
  }
  return 0;
}
