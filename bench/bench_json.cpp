// JSON I/O of a large job (server/codec/json_codec.h), the DOM way and the direct way, each in its own forked
// process so that its peak resident memory is its own:
//   read   parse_json + parametrize_request_from_json (a DOM of the whole body)  vs
//          parametrize_request_from_text (SAX straight into the engine's arrays)
//   write  dump(parametrize_result_to_json(r))  vs  parametrize_result_to_text(r)
// on a request made from one shared mesh subdivided 1-to-4 (bench/subdivide.h) N times (default 0, 1, 2:
// 63k, 253k, 1M triangles), boundary on a circle; the answer is the mesh itself with its planar xy as uv and
// no inserted vertices (the size of a real answer for that mesh). Checks that both ways give the same request
// and the same bytes. --runs N: each way runs N times in its child, which reports the median (the machine is
// shared); --no-dom leaves the DOM ways out.
//
//   bench_json [--levels N] [--mesh NAME] [--runs N] [--no-dom]
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <functional>
#include <string>
#include <vector>

#include "engine/mesh_io.h"
#include "engine/mesh_topology.h"
#include "engine/pipeline.h"
#include "server/codec/json_codec.h"
#include "subdivide.h"
#include "tests/support/test_meshes.h"

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

int g_runs = 1;

// Runs fn g_runs times in a child; returns "ms peak_MB" (the median of fn's own ms, and the first run's,
// which alone pays for fresh pages) or "error".
std::string in_child(const std::function<double()>& fn) {
  int fd[2];
  if (pipe(fd) != 0) return "error";
  std::fflush(stdout);
  const pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
    std::vector<double> runs;
    for (int k = 0; k < g_runs; ++k) runs.push_back(fn());
    const double first = runs[0];
    std::nth_element(runs.begin(), runs.begin() + runs.size() / 2, runs.end());
    struct rusage ru {};
    getrusage(RUSAGE_SELF, &ru);
    char buf[96];
    const int n = g_runs == 1 ? std::snprintf(buf, sizeof buf, "%.1f ms, peak %.0f MB", first, ru.ru_maxrss / 1024.0)
                              : std::snprintf(buf, sizeof buf, "%.1f ms (first %.1f), peak %.0f MB",
                                              runs[runs.size() / 2], first, ru.ru_maxrss / 1024.0);
    if (write(fd[1], buf, n) < 0) _exit(1);
    _exit(0);
  }
  close(fd[1]);
  char buf[128] = {0};
  const ssize_t n = read(fd[0], buf, sizeof buf - 1);
  close(fd[0]);
  waitpid(pid, nullptr, 0);
  return n > 0 ? std::string(buf, n) : "error";
}

}  // namespace

int main(int argc, char** argv) {
  int levels = 2;
  std::string name = "max_registration_partial";
  bool dom = true;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--levels") && i + 1 < argc) levels = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--mesh") && i + 1 < argc) name = argv[++i];
    else if (!std::strcmp(argv[i], "--runs") && i + 1 < argc) g_runs = std::max(1, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--no-dom")) dom = false;
  }
  std::vector<lipmap::Point3> vertices;
  std::vector<lipmap::Triangle> faces;
  for (const auto& entry : lipmap::testmeshes::disk_meshes())
    if (entry.name() == name) {
      const lipmap::RawMesh raw = lipmap::read_mesh_file(entry.path());
      vertices = raw.vertices;
      for (const auto& f : raw.faces) faces.push_back({int(f[0]), int(f[1]), int(f[2])});
    }
  if (faces.empty()) return 0;
  std::printf("# JSON I/O of a parametrize job: time and peak RSS of each way, in its own process\n");
  for (int level = 0; level <= levels; ++level) {
    if (level > 0) lipmap::bench::subdivide(vertices, faces);
    const lipmap::MeshTopology topo(static_cast<int>(vertices.size()), faces);
    const std::vector<int>& loop = topo.boundary_loops().front();
    lipmap::codec::ParametrizeRequest request;
    request.mesh.vertices = vertices;
    for (const auto& t : faces) request.mesh.faces.push_back({t[0], t[1], t[2]});
    request.boundary.vertices = std::vector<long long>(loop.begin(), loop.end());
    for (std::size_t k = 0; k < loop.size(); ++k) {
      const double a = 2 * M_PI * double(k) / double(loop.size());
      request.boundary.positions.push_back({std::cos(a), std::sin(a)});
    }
    const std::string body = lipmap::codec::dump(lipmap::codec::parametrize_request_to_json(request));
    lipmap::ParametrizeResult result;
    result.map.vertices = vertices;
    result.map.faces = faces;
    for (const auto& p : vertices) result.map.uv.push_back({p.x, p.y});
    result.boundary_loop = loop;
    result.classification.rotation_indices.assign(loop.size(), 0);

    // What every child starts with (the parent's body, request and answer, shared after fork).
    const std::string baseline = in_child([&] {
      volatile std::size_t touched = 0;
      for (std::size_t i = 0; i < body.size(); i += 4096) touched = touched + static_cast<unsigned char>(body[i]);
      return 0.0;
    });
    const std::string dom_read = !dom ? "-" : in_child([&] {
      const auto t0 = Clock::now();
      const auto r = lipmap::codec::parametrize_request_from_json(lipmap::codec::parse_json(body));
      return ms_since(t0) + 0 * r.mesh.faces.size();
    });
    const std::string sax_read = in_child([&] {
      const auto t0 = Clock::now();
      const auto r = lipmap::codec::parametrize_request_from_text(body);
      if (!r || r->mesh.faces.size() != faces.size()) std::abort();
      return ms_since(t0);
    });
    // As the service reads a body when its pool is idle, and `lipmap map` always (a helper thread reads the
    // first big array).
    const std::string sax_read2 = in_child([&] {
      const auto t0 = Clock::now();
      const auto r = lipmap::codec::parametrize_request_from_text(body, 0, 2);
      if (!r || r->mesh.faces.size() != faces.size() || r->mesh.vertices.size() != vertices.size()) std::abort();
      return ms_since(t0);
    });
    const std::string dom_write = !dom ? "-" : in_child([&] {
      const auto t0 = Clock::now();
      const std::string text = lipmap::codec::dump(lipmap::codec::parametrize_result_to_json(result));
      return ms_since(t0) + 0 * text.size();
    });
    const std::string text_write = in_child([&] {
      const auto t0 = Clock::now();
      const std::string text = lipmap::codec::parametrize_result_to_text(result);
      return ms_since(t0) + 0 * text.size();
    });
    const std::string text_write2 = in_child([&] {
      const auto t0 = Clock::now();
      const std::string text = lipmap::codec::parametrize_result_to_text(result, false, 2);
      return ms_since(t0) + 0 * text.size();
    });
    const bool same = lipmap::codec::parametrize_result_to_text(result) ==
                      lipmap::codec::dump(lipmap::codec::parametrize_result_to_json(result));
    std::printf("%zu triangles, body %.1f MB (a child's start: %s): read DOM %s | read SAX %s | on 2 threads %s; "
                "write DOM %s | write direct %s | on 2 threads %s; same bytes: %s\n",
                faces.size(), body.size() / 1e6, baseline.c_str(), dom_read.c_str(), sax_read.c_str(), sax_read2.c_str(),
                dom_write.c_str(), text_write.c_str(), text_write2.c_str(), same ? "yes" : "NO");
    std::fflush(stdout);
  }
  return 0;
}
