// Benchmark of the whole engine (engine/pipeline.h) in the form of the paper's Table 1, with CGAL's own Tutte
// parameterization of the same mesh for comparison.
//
//   bench_pipeline [--quick] [--runs N] [--mesh NAME]... [--data DIR] [--budget-s S] [--large[=N]]
//                  [--large-mesh NAME] [--rounds R] [--no-peer] [--optimize NAME]
//
// --no-peer: CGAL's Tutte is not run (ratio "-"): for profiling runs of lipmap alone (CGAL takes over a minute
// at 1M triangles). --optimize NAME (none, mips, symmetric_dirichlet; default the engine's, mips): the optimize
// stage's energy, none to time the map's own cost.
//
// --large[=N] (N = 1 or 2, default 2): instead of the catalog, rows at ~250k (N >= 1) and ~1M (N = 2) triangles,
// made here by 1-to-4 subdivision (each triangle into four at its edge midpoints) of one shared mesh
// (--large-mesh, default max_registration_partial: 63k triangles -> 253k -> 1.01M), each with the per-stage
// times, CGAL's Tutte in the same run, and summary lines with the growth factor between the sizes. --rounds R
// (default 1): CGAL once per size, then R rounds each running every row of both sizes once; the summary lines
// give the median of the rounds (the growth: of the rounds' own ratios, and their range). On a shared VM a
// spell of load lasts minutes and can make one size 40 % slower than usual; rows minutes apart then tell more
// about the machine than about the growth (docs/architecture.md).
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
#include <memory>
#include <stdexcept>
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
#include "engine/mesh_topology.h"
#include "subdivide.h"
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

// The boundary loop starting at its lowest vertex (the engine's topology; the bench meshes are disks).
std::vector<int> boundary_loop(const std::vector<Triangle>& faces, std::size_t nv) {
  const lipmap::MeshTopology topo(static_cast<int>(nv), faces);
  return topo.boundary_loops().empty() ? std::vector<int>{} : topo.boundary_loops().front();
}

// The mesh subdivided 1-to-4 (bench/subdivide.h), with its new boundary loop.
Mesh subdivide(const Mesh& m) {
  Mesh out = m;
  out.name = m.name + "/4";
  lipmap::bench::subdivide(out.vertices, out.faces);
  out.loop = boundary_loop(out.faces, out.vertices.size());
  return out;
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
  // Medians per stage: validate, classify, target_mesh, intermediate_maps, compose, refine, verify, quality,
  // untangle, optimize.
  static constexpr int kStages = 10;
  double stage[kStages] = {-1, -1, -1, -1, -1, -1, -1, -1, -1, -1};
  long long target_vertices = -1;
  double mean_k = -1, max_k = -1;  // the answer's conformal distortion (of the last run: runs give the same map)
  long rss_kb = -1;
  std::string source_solution = "-", target_solution = "-";
};

// The engine's options of every row (--optimize changes the energy).
lipmap::ParametrizeOptions g_options;  // the defaults: harmonic, refine, density 1 (the paper), untangle, optimize mips

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
  const lipmap::ParametrizeOptions& options = g_options;
  std::vector<double> tri, maps, cr, uo, total, other, stage[Row::kStages];
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
      const double each[Row::kStages] = {s.validate, s.classify, s.target_mesh, s.intermediate_maps, s.compose,
                                         s.refine,   s.verify,   s.quality,     s.untangle,          s.optimize};
      for (int i = 0; i < Row::kStages; ++i) stage[i].push_back(each[i]);
      row.target_vertices = res.target_mesh.vertices;
      row.mean_k = res.distortion.mean;
      row.max_k = res.distortion.max;
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
  for (int i = 0; i < Row::kStages; ++i) row.stage[i] = median(stage[i]);
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
  std::string line = buf;
  for (double v : r.stage) {
    std::snprintf(buf, sizeof buf, "\t%.6f", v);
    line += buf;
  }
  std::snprintf(buf, sizeof buf, "\t%lld\t%.17g\t%.17g", r.target_vertices, r.mean_k, r.max_k);
  return line + buf;
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
  for (int i = 0; i < Row::kStages && 17 + i < static_cast<int>(f.size()); ++i) r.stage[i] = std::atof(f[17 + i].c_str());
  if (f.size() > 17 + Row::kStages) r.target_vertices = std::atoll(f[17 + Row::kStages].c_str());
  if (f.size() > 19 + Row::kStages) {
    r.mean_k = std::atof(f[18 + Row::kStages].c_str());
    r.max_k = std::atof(f[19 + Row::kStages].c_str());
  }
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

static bool g_peer = true;  // false (--no-peer): CGAL's Tutte is not run

// CGAL's Tutte map of m in a process of its own (median of `runs`): its time in ms, or -1 with *error set (empty
// when the peer is not run).
double peer_ms(const Mesh& m, int runs, std::string* error) {
  if (!g_peer) return -1;
  const std::string line = isolated([&] {
    std::string err;
    const double ms = cgal_tutte_ms(m, runs, &err);
    return err.empty() ? "cgal\t" + std::to_string(ms) : "error\t" + err;
  });
  const std::vector<std::string> f = split(line);
  if (f.size() >= 2 && f[0] == "cgal") return std::atof(f[1].c_str());
  *error = f.size() >= 2 ? f[1] : line;
  return -1;
}

// The rows' targets: a circle and the first certified self-overlapping kind.
std::vector<lipmap::targetgen::Target> row_targets(const Mesh& m) {
  std::vector<lipmap::targetgen::Target> targets;
  std::string why;
  const lipmap::targetgen::DiskMeshRef ref{m.vertices, m.faces, m.loop};
  if (auto t = lipmap::targetgen::make_target(Kind::circle, ref, &why)) targets.push_back(*t);
  for (Kind k : {Kind::exp_strip, Kind::power_map, Kind::cubic_map, Kind::bent_strip})
    if (auto t = lipmap::targetgen::make_target(k, ref, &why)) {
      targets.push_back(*t);
      break;
    }
  return targets;
}

// One row, run in a process of its own.
Row measure_row(const Mesh& m, const lipmap::targetgen::Target& t, int runs, double budget_s) {
  return decode(isolated([&] { return encode(run_row(m, t, runs, budget_s)); }, static_cast<unsigned>(budget_s) + 30));
}

// A row's table line (with stages, its stages line too).
void print_row(const std::string& name, const char* kind, const Row& r, bool stages, double cgal_ms) {
  if (!r.error.empty()) {
    std::printf("%-26s %-11s error: %s\n", name.c_str(), kind, r.error.c_str());
    return;
  }
  char ratio[32] = "-";
  if (cgal_ms > 0 && r.total > 0) std::snprintf(ratio, sizeof ratio, "%.2f", r.total / cgal_ms);
  std::printf("%-26s %-11s %-24s %7lld %7lld %6lld %5lld %9s %9s %9s %9s %9s %8s %8.1f %9s %7s\n", name.c_str(),
              kind, r.verdict.c_str(), r.vertices, r.triangles, r.boundary,
              r.inserted, cell_ms(r.triangulation).c_str(), cell_ms(r.maps).c_str(),
              cell_ms(r.compose_refine).c_str(), cell_ms(r.untangle_optimize).c_str(), cell_ms(r.total).c_str(),
              cell_ms(r.other).c_str(),
              r.rss_kb / 1024.0, cell_ms(cgal_ms).c_str(), ratio);
  if (stages)
    std::printf("  stages ms: validate %s, classify %s, target_mesh %s (%lld vertices), intermediate_maps %s "
                "(source %s, target %s), compose %s, refine %s, verify %s, quality %s, untangle %s, optimize %s; "
                "mean K %.4f, max K %.3f\n",
                cell_ms(r.stage[0]).c_str(), cell_ms(r.stage[1]).c_str(), cell_ms(r.stage[2]).c_str(),
                r.target_vertices, cell_ms(r.stage[3]).c_str(), r.source_solution.c_str(), r.target_solution.c_str(),
                cell_ms(r.stage[4]).c_str(),
                cell_ms(r.stage[5]).c_str(), cell_ms(r.stage[6]).c_str(), cell_ms(r.stage[7]).c_str(),
                cell_ms(r.stage[8]).c_str(), cell_ms(r.stage[9]).c_str(), r.mean_k, r.max_k);
  std::fflush(stdout);
}

// The large rows of one size, for rounds that alternate between sizes: a process that makes the mesh (the base
// subdivided `level` times) and its targets, measures CGAL's Tutte once, then runs the rows it is asked for,
// each in a child of its own. A row's peak resident set then holds its own size's mesh, as it does when the
// sizes are run one after the other; with every size's mesh in one parent, each row's process (a fork of it)
// would count the other sizes' too (about 50 MB at 253k).
class SizeHost {
 public:
  SizeHost(const Mesh& base, int level, int runs, double budget_s) {
    int down[2], up[2];
    if (pipe(down) != 0 || pipe(up) != 0) throw std::runtime_error("pipe failed");
    std::fflush(stdout);
    pid_ = fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      // Only its own pipe ends stay open: a host that kept an earlier host's would keep that one from ever
      // reading the end of its input.
      const unsigned lo = static_cast<unsigned>(std::min(down[0], up[1])), hi = static_cast<unsigned>(std::max(down[0], up[1]));
      close_range(3, lo - 1, 0);
      close_range(lo + 1, hi - 1, 0);
      close_range(hi + 1, ~0U, 0);
      FILE* in = fdopen(down[0], "r");
      FILE* out = fdopen(up[1], "w");
      Mesh m = base;
      for (int l = 0; l < level; ++l) m = subdivide(m);
      std::string error;
      const double cgal = peer_ms(m, runs, &error);
      for (char& c : error)
        if (c == '\t' || c == '\n') c = ' ';
      const std::vector<lipmap::targetgen::Target> targets = row_targets(m);
      std::fprintf(out, "%s\t%zu\t%.6f\t%s", m.name.c_str(), m.faces.size(), cgal, error.c_str());
      for (const auto& t : targets) std::fprintf(out, "\t%s", lipmap::targetgen::kind_name(t.kind));
      std::fprintf(out, "\n");
      std::fflush(out);
      char line[64];
      while (std::fgets(line, sizeof line, in)) {
        const std::size_t t = static_cast<std::size_t>(std::atoi(line));
        Row r;
        if (t < targets.size()) r = measure_row(m, targets[t], runs, budget_s);
        else r.error = "no target " + std::to_string(t);
        std::fprintf(out, "%s\n", encode(r).c_str());
        std::fflush(out);
      }
      _exit(0);
    }
    close(down[0]);
    close(up[1]);
    to_ = fdopen(down[1], "w");
    from_ = fdopen(up[0], "r");
    const std::vector<std::string> f = split(read_line());
    if (f.size() < 4) throw std::runtime_error("the size host died");
    name = f[0];
    triangles = std::atoll(f[1].c_str());
    cgal_ms = std::atof(f[2].c_str());
    cgal_error = f[3];
    kinds.assign(f.begin() + 4, f.end());
  }
  ~SizeHost() {
    std::fclose(to_);  // the host's loop ends at end of input
    std::fclose(from_);
    waitpid(pid_, nullptr, 0);
  }
  SizeHost(const SizeHost&) = delete;
  SizeHost& operator=(const SizeHost&) = delete;

  Row row(std::size_t t) {
    std::fprintf(to_, "%zu\n", t);
    std::fflush(to_);
    const std::string line = read_line();
    return line.empty() ? decode("error\tthe size host died") : decode(line);
  }

  std::string name, cgal_error;
  long long triangles = 0;
  double cgal_ms = -1;
  std::vector<std::string> kinds;

 private:
  std::string read_line() {
    std::string line;
    char buf[4096];
    while (std::fgets(buf, sizeof buf, from_)) {
      line += buf;
      if (!line.empty() && line.back() == '\n') {
        line.pop_back();
        break;
      }
    }
    return line;
  }
  pid_t pid_ = -1;
  FILE* to_ = nullptr;
  FILE* from_ = nullptr;
};

// One catalog mesh's rows: CGAL's Tutte once, then lipmap on a circle and on the first certified
// self-overlapping target. Prints the table lines (and, with stages, one line per row: the per-stage times and
// the answer's mean and max conformal distortion K).
void bench_mesh(const Mesh& m, int runs, double budget_s, bool stages) {
  std::string cgal_error;
  const double cgal_ms = peer_ms(m, runs, &cgal_error);
  for (const auto& t : row_targets(m))
    print_row(m.name, lipmap::targetgen::kind_name(t.kind), measure_row(m, t, runs, budget_s), stages, cgal_ms);
  if (!cgal_error.empty()) std::printf("%-26s CGAL Tutte failed: %s\n", m.name.c_str(), cgal_error.c_str());
}

int main(int argc, char** argv) {
  int runs = 3;
  double budget_s = 300;
  std::vector<std::string> only;
  int large = 0;  // subdivision levels of the large rows; 0: the catalog
  int rounds = 1;  // of the large rows
  bool stages = false;
  std::string large_mesh = "max_registration_partial";
  std::string data = default_data_dir();
  if (const char* env = std::getenv("LIPMAP_DATA_DIR"); env && *env) data = env;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--quick")) runs = 1;
    else if (!std::strcmp(argv[i], "--runs") && i + 1 < argc) runs = std::max(1, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--mesh") && i + 1 < argc) only.push_back(argv[++i]);
    else if (!std::strcmp(argv[i], "--data") && i + 1 < argc) data = argv[++i];
    else if (!std::strcmp(argv[i], "--budget-s") && i + 1 < argc) budget_s = std::max(1.0, std::atof(argv[++i]));
    else if (!std::strcmp(argv[i], "--large")) large = 2;
    else if (!std::strncmp(argv[i], "--large=", 8)) large = std::clamp(std::atoi(argv[i] + 8), 1, 2);
    else if (!std::strcmp(argv[i], "--large-mesh") && i + 1 < argc) large_mesh = argv[++i];
    else if (!std::strcmp(argv[i], "--rounds") && i + 1 < argc) rounds = std::max(1, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--stages")) stages = true;
    else if (!std::strcmp(argv[i], "--no-peer")) g_peer = false;
    else if (!std::strcmp(argv[i], "--optimize") && i + 1 < argc &&
             lipmap::parse_optimize_energy(argv[i + 1], g_options.optimize)) ++i;
    else {
      std::printf("usage: %s [--quick] [--runs N] [--mesh NAME]... [--data DIR] [--budget-s S] [--stages] "
                  "[--large[=1|2]] [--large-mesh NAME] [--rounds R] [--no-peer] [--optimize none|mips|symmetric_dirichlet]\n", argv[0]);
      return 0;
    }
  }

  struct utsname u {};
  uname(&u);
  std::printf("bench_pipeline: lipmap::parametrize (harmonic, refine, target density 1, untangle, optimize %s) vs CGAL Tutte "
              "(Barycentric_mapping_parameterizer_3 + Circular_border_arc_length_parameterizer_3)%s\n",
              lipmap::to_string(g_options.optimize), g_peer ? "" : " [--no-peer: CGAL not run]");
  std::printf("machine: %s %s %s %s; %u hardware threads (nproc); %s\n", u.sysname, u.nodename, u.release, u.machine,
              std::thread::hardware_concurrency(), cpu_model().c_str());
  // The allocator's setting changes large-mesh times by up to 2x on VMs (docs/architecture.md, "Huge pages").
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  std::printf("malloc: GLIBC_TUNABLES=%s\n", tunables && *tunables ? tunables
                                   : "(unset: glibc's defaults; the lipmap binary and the container image use "
                                     "docs/architecture.md's \"Huge pages\" settings)");
  std::printf("median of %d run%s per row (budget %.0f s per row); times in ms; peak = max resident set of the row's "
              "own process\n", runs, runs == 1 ? "" : "s", budget_s);
  std::printf("\n%-26s %-11s %-24s %7s %7s %6s %5s %9s %9s %9s %9s %9s %8s %8s %9s %7s\n", "model", "target", "verdict",
              "#vert", "#tri", "#bnd", "#ins", "triang.", "2 maps", "comp+ref", "unt+opt", "total", "other", "peak MB",
              "CGAL Tut", "ratio");
  std::printf("%s\n", std::string(180, '-').c_str());

  if (large > 0) {
    // The large rows: one shared mesh subdivided 1-to-4 once (~250k triangles) and, with --large=2, twice (~1M).
    Mesh base;
    bool found = false;
    for (const lipmap::testmeshes::MeshEntry& entry : lipmap::testmeshes::disk_meshes())
      if (entry.name() == large_mesh) {
        base = load(data, entry);
        found = true;
      }
    if (!found) {
      std::printf("no disk mesh named %s in the catalog\n", large_mesh.c_str());
      return 0;
    }
    // CGAL once per size; then `rounds` rounds, each running every row of every size once (each row in its own
    // process, `runs` runs): the rows of the two sizes are measured seconds apart rather than minutes (CGAL's 1M
    // map takes half a minute), and the growth is the median of the rounds' own ratios, so that a spell of load
    // on the machine (a shared VM's neighbours) falls on both sizes of a round alike.
    std::vector<std::unique_ptr<SizeHost>> hosts;
    for (int level = 1; level <= large; ++level) {
      hosts.push_back(std::make_unique<SizeHost>(base, level, runs, budget_s));
      if (!hosts.back()->cgal_error.empty())
        std::printf("%-26s CGAL Tutte failed: %s\n", hosts.back()->name.c_str(), hosts.back()->cgal_error.c_str());
    }
    // rows[size][target][round]
    std::vector<std::vector<std::vector<Row>>> rows(hosts.size());
    for (std::size_t l = 0; l < hosts.size(); ++l) rows[l].resize(hosts[l]->kinds.size());
    for (int round = 0; round < rounds; ++round) {
      if (rounds > 1) std::printf("# round %d of %d\n", round + 1, rounds);
      for (std::size_t l = 0; l < hosts.size(); ++l)
        for (std::size_t t = 0; t < hosts[l]->kinds.size(); ++t) {
          rows[l][t].push_back(hosts[l]->row(t));
          print_row(hosts[l]->name, hosts[l]->kinds[t].c_str(), rows[l][t].back(), true, hosts[l]->cgal_ms);
        }
    }
    auto median_field = [](const std::vector<Row>& rs, auto field) {
      std::vector<double> v;
      for (const Row& r : rs)
        if (r.error.empty()) v.push_back(field(r));
      return median(v);
    };
    std::printf("\n");
    for (std::size_t l = 0; l < hosts.size(); ++l)
      for (std::size_t t = 0; t < hosts[l]->kinds.size(); ++t) {
        const std::vector<Row>& rs = rows[l][t];
        const auto good = std::find_if(rs.begin(), rs.end(), [](const Row& r) { return r.error.empty(); });
        if (good == rs.end()) continue;
        const long ok = std::count_if(rs.begin(), rs.end(), [](const Row& r) { return r.error.empty(); });
        const double total = median_field(rs, [](const Row& r) { return r.total; });
        const double rss = median_field(rs, [](const Row& r) { return static_cast<double>(r.rss_kb); });
        const double cgal = hosts[l]->cgal_ms;
        char of[64] = "";
        if (rounds > 1) std::snprintf(of, sizeof of, " (median of %ld rounds)", ok);
        std::printf("summary: %s %lldk triangles, %s: lipmap %.2f s%s, CGAL Tutte %.2f s, ratio %.2f, peak RSS %.0f MB, "
                    "inserted %lld, target mesh %lld vertices\n", large_mesh.c_str(), hosts[l]->triangles / 1000,
                    hosts[l]->kinds[t].c_str(), total / 1000, of, cgal / 1000, cgal > 0 ? total / cgal : -1,
                    rss / 1024.0, good->inserted, good->target_vertices);
      }
    if (hosts.size() == 2)
      for (std::size_t t = 0; t < hosts[0]->kinds.size(); ++t) {
        // The same target kind at both sizes (the self-overlapping kind is the first each size certifies).
        const auto u = std::find(hosts[1]->kinds.begin(), hosts[1]->kinds.end(), hosts[0]->kinds[t]);
        if (u == hosts[1]->kinds.end()) continue;
        const std::vector<Row>&a = rows[0][t], &b = rows[1][static_cast<std::size_t>(u - hosts[1]->kinds.begin())];
        std::vector<double> total, maps, rss;  // over the rounds where both sizes' rows ran
        for (int r = 0; r < rounds; ++r) {
          if (!a[r].error.empty() || !b[r].error.empty()) continue;
          total.push_back(b[r].total / a[r].total);
          maps.push_back(b[r].stage[3] / a[r].stage[3]);
          rss.push_back(double(b[r].rss_kb) / double(a[r].rss_kb));
        }
        if (total.empty()) continue;
        std::string spread;
        if (rounds > 1) {
          char buf[96];
          std::snprintf(buf, sizeof buf, " (median of %zu rounds' ratios; rounds %.2fx-%.2fx)", total.size(),
                        *std::min_element(total.begin(), total.end()), *std::max_element(total.begin(), total.end()));
          spread = buf;
        }
        char cgal[32] = "-";
        if (hosts[0]->cgal_ms > 0 && hosts[1]->cgal_ms > 0)
          std::snprintf(cgal, sizeof cgal, "%.2fx", hosts[1]->cgal_ms / hosts[0]->cgal_ms);
        std::printf("summary: growth %lldk -> %lldk triangles (%.2fx), %s: lipmap total %.2fx%s, two maps %.2fx, "
                    "CGAL Tutte %s, peak RSS %.2fx\n", hosts[0]->triangles / 1000, hosts[1]->triangles / 1000,
                    double(hosts[1]->triangles) / double(hosts[0]->triangles), hosts[0]->kinds[t].c_str(),
                    median(total), spread.c_str(), median(maps), cgal, median(rss));
      }
  } else {
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
      bench_mesh(m, runs, budget_s, stages);
    }
  }
  std::printf("\ncolumns: triang. = classify + target mesh; 2 maps = both intermediate maps onto the disk; comp+ref = "
              "compose + refine; unt+opt = untangle + optimize; total = the whole parametrize call; other = validate + verify + quality (inside "
              "total); CGAL Tut = CGAL's Tutte map of the same mesh (parameterize() only); ratio = total / CGAL Tut\n");
  return 0;
}
