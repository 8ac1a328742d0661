// Benchmark of the whole engine (engine/pipeline.h) in the form of the paper's Table 1, with CGAL's own Tutte
// parameterization of the same mesh for comparison.
//
//   bench_pipeline [--quick] [--runs N] [--mesh NAME]... [--data DIR] [--budget-s S]
//
// Rows: every disk mesh of tests/data/meshes (DIR/meshes) with two generated targets
// (tests/support/target_generators.h): a circle, and a self-overlapping boundary by construction (exp_strip,
// else power_map, cubic_map, bent_strip: the first the generator can certify for that mesh). Columns:
// vertices, triangles, boundary vertices, inserted vertices, then the median over N runs (default 3;
// --quick: 1) of the time per stage in the paper's grouping:
//   triangulation          classify + target mesh
//   two harmonic maps      intermediate_maps (both maps onto the disk; harmonic = cotangent weights)
//   composition + refine   compose + refine
//   untangle + optimize    the stages after the paper's (engine/untangle.h, engine/optimize.h)
//   total                  the whole call (also validate, verify and quality, which the paper's table has not)
// and the peak resident memory of the process that ran the row (each row runs in its own forked child, so
// ru_maxrss is that row's peak). In the same run, for each mesh: CGAL's Tutte parameterization
// (Surface_mesh_parameterization::Barycentric_mapping_parameterizer_3 with
// Circular_border_arc_length_parameterizer_3 on a CGAL::Surface_mesh of the same vertices and faces; median
// of N runs of parameterize() alone, the Surface_mesh construction not counted), and the ratio of lipmap's
// total to it. A row gets S seconds in all (default 300; the pipeline is cancelled through its CancelToken,
// and the row's process is killed 30 s later as a backstop): "timeout" instead of numbers. Always exits 0; a
// row whose pipeline throws prints the error instead of numbers.
#include <sys/resource.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <thread>
#include <vector>

// CGAL's parameterization package solves with Eigen (CGAL::Eigen3_support, bench/CMakeLists.txt); its
// headers stay in this file (BUILD-NOTES: heavy).
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_parameterization/Barycentric_mapping_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/Circular_border_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/parameterize.h>
#include <CGAL/Polygon_mesh_processing/measure.h>

#include "../tests/support/target_generators.h"
#include "engine/cancel.h"
#include "engine/error.h"
#include "engine/mesh_io.h"
#include "engine/pipeline.h"
#include "tests/support/test_meshes.h"

namespace {

using Clock = std::chrono::steady_clock;
using lipmap::Point2;
using lipmap::Point3;
using lipmap::Triangle;
using lipmap::targetgen::Kind;

// The repository's test data (tests/data), set by bench/CMakeLists.txt.
std::string default_data_dir() { return LIPMAP_DATA_DIR; }

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

double median(std::vector<double> v) {
  if (v.empty()) return -1;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

struct Mesh {
  std::string name;
  std::vector<Point3> vertices;
  std::vector<Triangle> faces;
  std::vector<int> loop;
};

std::vector<int> boundary_loop(const std::vector<Triangle>& faces, std::size_t nv) {
  std::map<std::pair<int, int>, int> directed;
  for (const Triangle& t : faces)
    for (int c = 0; c < 3; ++c) ++directed[{t[c], t[(c + 1) % 3]}];
  std::vector<int> next(nv, -1);
  int start = -1;
  for (const auto& [e, n] : directed) {
    if (directed.count({e.second, e.first})) continue;
    next[e.first] = e.second;
    if (start < 0 || e.first < start) start = e.first;
  }
  std::vector<int> loop;
  for (int v = start; v >= 0 && loop.size() <= nv;) {
    loop.push_back(v);
    v = next[v];
    if (v == start) break;
  }
  return loop;
}

Mesh load(const std::string& dir, const lipmap::testmeshes::MeshEntry& entry) {
  const lipmap::RawMesh raw = lipmap::read_mesh_file(entry.extra ? entry.file : dir + "/meshes/" + entry.file);
  Mesh m;
  m.name = entry.name();
  m.vertices = raw.vertices;
  for (const auto& f : raw.faces) m.faces.push_back({int(f[0]), int(f[1]), int(f[2])});
  m.loop = boundary_loop(m.faces, m.vertices.size());
  return m;
}

// ---- CGAL's Tutte map --------------------------------------------------------------------------------

double cgal_tutte_ms(const Mesh& m, int runs, std::string* error) {
  using Kernel = CGAL::Simple_cartesian<double>;
  using SM = CGAL::Surface_mesh<Kernel::Point_3>;
  namespace SMP = CGAL::Surface_mesh_parameterization;
  using Border = SMP::Circular_border_arc_length_parameterizer_3<SM>;
  using Parameterizer = SMP::Barycentric_mapping_parameterizer_3<SM, Border>;
  std::vector<double> ms;
  for (int r = 0; r < runs; ++r) {
    SM sm;
    std::vector<SM::Vertex_index> vh;
    vh.reserve(m.vertices.size());
    for (const Point3& p : m.vertices) vh.push_back(sm.add_vertex(Kernel::Point_3(p.x, p.y, p.z)));
    for (const Triangle& t : m.faces)
      if (sm.add_face(vh[t[0]], vh[t[1]], vh[t[2]]) == SM::null_face()) {
        if (error) *error = "CGAL Surface_mesh refused a face";
        return -1;
      }
    const auto bhd = CGAL::Polygon_mesh_processing::longest_border(sm).first;
    auto uv = sm.add_property_map<SM::Vertex_index, Kernel::Point_2>("v:uv").first;
    const auto t0 = Clock::now();
    const SMP::Error_code status = SMP::parameterize(sm, Parameterizer(), bhd, uv);
    ms.push_back(ms_since(t0));
    if (status != SMP::OK) {
      if (error) *error = std::string("CGAL: ") + SMP::get_error_message(status);
      return -1;
    }
  }
  return median(ms);
}

// ---- one row: lipmap on (mesh, target) ----------------------------------------------------------------

struct Row {
  std::string error;
  std::string verdict = "-";
  long long vertices = 0, triangles = 0, boundary = 0, inserted = -1, flipped_before = -1;
  double triangulation = -1, maps = -1, compose_refine = -1, untangle_optimize = -1, total = -1, other = -1;
  long rss_kb = -1;
  std::string source_solution = "-", target_solution = "-";
};

Row run_row(const Mesh& m, const lipmap::targetgen::Target& t, int runs, double budget_s) {
  Row row;
  row.vertices = static_cast<long long>(m.vertices.size());
  row.triangles = static_cast<long long>(m.faces.size());
  row.boundary = static_cast<long long>(m.loop.size());
  lipmap::RawMesh raw;
  raw.vertices = m.vertices;
  for (const Triangle& f : m.faces) raw.faces.push_back({f[0], f[1], f[2]});
  lipmap::RawBoundary b;
  b.positions = t.positions;
  if (t.rotation_indices) b.rotation_indices = std::vector<long long>(t.rotation_indices->begin(), t.rotation_indices->end());
  lipmap::ParametrizeOptions options;  // the defaults: harmonic, refine, density 1 (the paper), untangle, optimize mips
  std::vector<double> tri, maps, cr, uo, total, other;
  lipmap::CancelToken token;
  token.set_deadline(Clock::now() + std::chrono::milliseconds(static_cast<long long>(budget_s * 1000)));
  for (int r = 0; r < runs; ++r) {
    try {
      const lipmap::ParametrizeResult res = lipmap::parametrize(raw, b, options, &token);
      const lipmap::StageTimings& s = res.timings;
      tri.push_back(s.classify + s.target_mesh);
      maps.push_back(s.intermediate_maps);
      cr.push_back(s.compose + s.refine);
      uo.push_back(s.untangle + s.optimize);
      total.push_back(s.total);
      other.push_back(s.validate + s.verify + s.quality);
      row.inserted = static_cast<long long>(res.map.inserted.size());
      row.flipped_before = res.map.flipped_before_refinement;
      row.verdict = lipmap::to_string(res.classification.verdict);
      row.source_solution = lipmap::to_string(res.source_map_solution);
      row.target_solution = lipmap::to_string(res.target_map_solution);
    } catch (const lipmap::Cancelled&) {
      if (total.empty()) row.error = "timeout: over the budget of " + std::to_string(static_cast<int>(budget_s)) + " s";
      break;  // with some runs done: the median of those
    } catch (const lipmap::InputError& e) {
      row.error = e.code() + ": " + e.what();
      break;
    } catch (const std::exception& e) {
      row.error = e.what();
      break;
    }
  }
  row.triangulation = median(tri);
  row.maps = median(maps);
  row.compose_refine = median(cr);
  row.untangle_optimize = median(uo);
  row.total = median(total);
  row.other = median(other);
  struct rusage ru {};
  getrusage(RUSAGE_SELF, &ru);
  row.rss_kb = ru.ru_maxrss;
  return row;
}

// Runs fn in a forked child and returns the line it wrote (so that ru_maxrss is the child's own peak).
template <class Fn>
std::string isolated(Fn fn, unsigned kill_after_s = 0) {
  int fd[2];
  if (pipe(fd) != 0) return fn();
  std::fflush(stdout);
  const pid_t pid = fork();
  if (pid < 0) {
    close(fd[0]);
    close(fd[1]);
    return fn();
  }
  if (pid == 0) {
    close(fd[0]);
    if (kill_after_s > 0) alarm(kill_after_s);  // backstop: SIGALRM ends the child
    std::string line;
    try {
      line = fn();
    } catch (const std::exception& e) {
      line = std::string("error\t") + e.what();
    }
    std::size_t off = 0;
    while (off < line.size()) {
      const ssize_t w = write(fd[1], line.data() + off, line.size() - off);
      if (w <= 0) break;
      off += static_cast<std::size_t>(w);
    }
    close(fd[1]);
    _exit(0);
  }
  close(fd[1]);
  std::string text;
  char buf[4096];
  for (ssize_t n; (n = read(fd[0], buf, sizeof buf)) > 0;) text.append(buf, static_cast<std::size_t>(n));
  close(fd[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (text.empty()) text = "error\tthe child process died (signal " + std::to_string(WIFSIGNALED(status) ? WTERMSIG(status) : 0) + ")";
  return text;
}

std::string encode(const Row& r) {
  char buf[1024];
  std::string err = r.error;
  for (char& c : err)
    if (c == '\t' || c == '\n') c = ' ';
  std::snprintf(buf, sizeof buf, "row\t%s\t%lld\t%lld\t%lld\t%lld\t%lld\t%.6f\t%.6f\t%.6f\t%.6f\t%.6f\t%ld\t%s\t%s\t%s\t%.6f", r.verdict.c_str(),
                r.vertices, r.triangles, r.boundary, r.inserted, r.flipped_before, r.triangulation, r.maps,
                r.compose_refine, r.total, r.other, r.rss_kb, r.source_solution.c_str(), r.target_solution.c_str(),
                err.substr(0, 400).c_str(), r.untangle_optimize);
  return buf;
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::size_t b = 0;
  for (std::size_t i = 0; i <= s.size(); ++i)
    if (i == s.size() || s[i] == '\t') {
      out.push_back(s.substr(b, i - b));
      b = i + 1;
    }
  return out;
}

Row decode(const std::string& line) {
  Row r;
  const std::vector<std::string> f = split(line);
  if (f.size() < 17 || f[0] != "row") {
    r.error = f.size() >= 2 ? f[1] : line;
    return r;
  }
  r.verdict = f[1];
  r.vertices = std::atoll(f[2].c_str());
  r.triangles = std::atoll(f[3].c_str());
  r.boundary = std::atoll(f[4].c_str());
  r.inserted = std::atoll(f[5].c_str());
  r.flipped_before = std::atoll(f[6].c_str());
  r.triangulation = std::atof(f[7].c_str());
  r.maps = std::atof(f[8].c_str());
  r.compose_refine = std::atof(f[9].c_str());
  r.total = std::atof(f[10].c_str());
  r.other = std::atof(f[11].c_str());
  r.rss_kb = std::atol(f[12].c_str());
  r.source_solution = f[13];
  r.target_solution = f[14];
  r.error = f[15];
  r.untangle_optimize = std::atof(f[16].c_str());
  return r;
}

std::string cell_ms(double v) {
  char buf[32];
  if (v < 0) return "-";
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) {
      const auto p = line.find(':');
      return p == std::string::npos ? line : line.substr(p + 2);
    }
  return "unknown CPU";
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 3;
  double budget_s = 300;
  std::vector<std::string> only;
  std::string data = default_data_dir();
  if (const char* env = std::getenv("LIPMAP_DATA_DIR"); env && *env) data = env;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--quick")) runs = 1;
    else if (!std::strcmp(argv[i], "--runs") && i + 1 < argc) runs = std::max(1, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--mesh") && i + 1 < argc) only.push_back(argv[++i]);
    else if (!std::strcmp(argv[i], "--data") && i + 1 < argc) data = argv[++i];
    else if (!std::strcmp(argv[i], "--budget-s") && i + 1 < argc) budget_s = std::max(1.0, std::atof(argv[++i]));
    else {
      std::printf("usage: %s [--quick] [--runs N] [--mesh NAME]... [--data DIR] [--budget-s S]\n", argv[0]);
      return 0;
    }
  }

  struct utsname u {};
  uname(&u);
  std::printf("bench_pipeline: lipmap::parametrize (defaults: harmonic, refine, target density 1, untangle, optimize mips) vs CGAL Tutte "
              "(Barycentric_mapping_parameterizer_3 + Circular_border_arc_length_parameterizer_3)\n");
  std::printf("machine: %s %s %s %s; %u hardware threads (nproc); %s\n", u.sysname, u.nodename, u.release, u.machine,
              std::thread::hardware_concurrency(), cpu_model().c_str());
  std::printf("median of %d run%s per row (budget %.0f s per row); times in ms; peak = max resident set of the row's "
              "own process\n", runs, runs == 1 ? "" : "s", budget_s);
  std::printf("\n%-26s %-11s %-24s %7s %7s %6s %5s %9s %9s %9s %9s %9s %8s %8s %9s %7s\n", "model", "target", "verdict",
              "#vert", "#tri", "#bnd", "#ins", "triang.", "2 maps", "comp+ref", "unt+opt", "total", "other", "peak MB",
              "CGAL Tut", "ratio");
  std::printf("%s\n", std::string(180, '-').c_str());

  // Every disk mesh of the tests' catalog (tests/support/test_meshes.h), with $LIPMAP_EXTRA_MESHES.
  for (const lipmap::testmeshes::MeshEntry& entry : lipmap::testmeshes::disk_meshes()) {
    const std::string name = entry.name();
    if (!only.empty() && std::find(only.begin(), only.end(), name) == only.end()) continue;
    Mesh m;
    try {
      m = load(data, entry);
    } catch (const std::exception& e) {
      std::printf("%-26s cannot read: %s\n", name.c_str(), e.what());
      continue;
    }
    std::string cgal_error;
    const std::string cgal_line = isolated([&] {
      std::string err;
      const double ms = cgal_tutte_ms(m, runs, &err);
      return err.empty() ? "cgal\t" + std::to_string(ms) : "error\t" + err;
    });
    const std::vector<std::string> cf = split(cgal_line);
    const double cgal_ms = cf.size() >= 2 && cf[0] == "cgal" ? std::atof(cf[1].c_str()) : -1;
    if (cf.empty() || cf[0] != "cgal") cgal_error = cf.size() >= 2 ? cf[1] : cgal_line;

    // Targets: a circle and the first certified self-overlapping kind.
    std::vector<lipmap::targetgen::Target> targets;
    std::string why;
    const lipmap::targetgen::DiskMeshRef ref{m.vertices, m.faces, m.loop};
    if (auto t = lipmap::targetgen::make_target(Kind::circle, ref, &why)) targets.push_back(*t);
    for (Kind k : {Kind::exp_strip, Kind::power_map, Kind::cubic_map, Kind::bent_strip})
      if (auto t = lipmap::targetgen::make_target(k, ref, &why)) {
        targets.push_back(*t);
        break;
      }
    for (const auto& t : targets) {
      const Row r = decode(isolated([&] { return encode(run_row(m, t, runs, budget_s)); },
                                    static_cast<unsigned>(budget_s) + 30));
      if (!r.error.empty()) {
        std::printf("%-26s %-11s error: %s\n", name.c_str(), lipmap::targetgen::kind_name(t.kind), r.error.c_str());
        continue;
      }
      char ratio[32] = "-";
      if (cgal_ms > 0 && r.total > 0) std::snprintf(ratio, sizeof ratio, "%.2f", r.total / cgal_ms);
      std::printf("%-26s %-11s %-24s %7lld %7lld %6lld %5lld %9s %9s %9s %9s %9s %8s %8.1f %9s %7s\n", name.c_str(),
                  lipmap::targetgen::kind_name(t.kind), r.verdict.c_str(), r.vertices, r.triangles, r.boundary,
                  r.inserted, cell_ms(r.triangulation).c_str(), cell_ms(r.maps).c_str(),
                  cell_ms(r.compose_refine).c_str(), cell_ms(r.untangle_optimize).c_str(), cell_ms(r.total).c_str(), cell_ms(r.other).c_str(),
                  r.rss_kb / 1024.0, cell_ms(cgal_ms).c_str(), ratio);
      std::fflush(stdout);
    }
    if (!cgal_error.empty()) std::printf("%-26s CGAL Tutte failed: %s\n", name.c_str(), cgal_error.c_str());
  }
  std::printf("\ncolumns: triang. = classify + target mesh; 2 maps = both intermediate maps onto the disk; comp+ref = "
              "compose + refine; unt+opt = untangle + optimize; total = the whole parametrize call; other = validate + verify + quality (inside "
              "total); CGAL Tut = CGAL's Tutte map of the same mesh (parameterize() only); ratio = total / CGAL Tut\n");
  return 0;
}
