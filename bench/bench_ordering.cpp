// The fill-reducing ordering of the intermediate maps' factorization (engine/intermediate_map.cpp: CHOLMOD
// supernodal LLT of the interior block of the cotangent Laplacian), measured on one shared mesh and its 1-to-4
// subdivisions (bench/subdivide.h): for each of CHOLMOD's orderings (its default choice, AMD, METIS, CHOLMOD's
// nested dissection), the time of analyze (ordering + symbolic), factorize, one two-column solve, the
// factor's nonzeros and the residual of the solve. Single-threaded BLAS, as in the engine.
//
//   bench_ordering [--levels N (default 2)] [--mesh NAME (default max_registration_partial)] [--runs R (1)]

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <Eigen/CholmodSupport>
#include <Eigen/Sparse>

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
  std::string name = "max_registration_partial";
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--levels") && i + 1 < argc) levels = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--mesh") && i + 1 < argc) name = argv[++i];
    else if (!std::strcmp(argv[i], "--runs") && i + 1 < argc) runs = std::max(1, std::atoi(argv[++i]));
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
  std::printf("%-9s %8s %8s %-8s %9s %9s %8s %11s %9s\n", "triangles", "rows", "nnz(A)", "ordering", "analyze",
              "factor", "solve", "nnz(L)", "residual");
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
    for (const Ordering& o : orderings) {
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
        residual = (A * x - b).norm() / std::max(1e-300, b.norm());
        lnz = static_cast<long long>(llt.cholmod().lnz);
      }
      std::printf("%-9zu %8d %8ld %-8s %9.1f %9.1f %8.1f %11lld %9.1e\n", faces.size(), m, static_cast<long>(A.nonZeros()),
                  o.name, best_analyze, best_factor, best_solve, lnz, residual);
      std::fflush(stdout);
    }
  }
  return 0;
}
