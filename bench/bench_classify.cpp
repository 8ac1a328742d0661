// Benchmark of the classify stage (engine/classify.h).
//
//   bench_classify [--quick] [--runs N] [--budget-s S]
//   bench_classify --curve [--budget-s S]
//
// --curve: the cost curve behind the service's default --max-polygon-vertices (docs/hard-points.md): one
// classify of a heavily overlapping spiral strip (3 turns) at 2,000 .. 20,000 vertices each in its own child,
// and of a double loop (turning number 3: nothing for the ear reduction, turn masks in the table) at 500 ..
// 8,000, each in its own child, with its time, table memory and peak RSS; then how late a cancelled table
// fill stops (the token's deadline 1 s after the start, on the 8,000-vertex double loop).
//
// Cases: nearly simple boundaries (noisy circles, gently wavy star-shaped polygons) of 100 .. 5000
// vertices, where App. C's ear reduction should leave almost nothing for the O(n^3) table, and heavily
// overlapping spiral strips (a strip bent through 2, 3, 4 turns whose layers overlap) of 100 .. 1500
// vertices, where it cannot; then weakly self-overlapping double loops (turning number 3, 4) of 300 and
// 1000 vertices, classified freely and with the hub's rotation index given. For each case: median wall time of classify over N runs (default 5), the
// verdict, stats.reduced_vertices, stats.table_bytes, and the peak RSS of the process that ran the case.
// Each case runs in its own forked child so that ru_maxrss is that case's peak, not the running maximum.
// A case whose runs exceed the time budget stops early (marked '*' with the runs done); a single run that
// hits the budget is cancelled through the CancelToken and reported as a timeout. Always exits 0.
#define LIPMAP_TESTGEN_NO_CGAL
#include "../tests/support/polygon_generators.h"

#include <sys/resource.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "engine/cancel.h"
#include "engine/classify.h"

namespace {

using lipmap::testgen::Poly;
using lipmap::testgen::Rng;

struct Case {
  std::string kind;
  int n_requested = 0;
  Poly poly;
  std::optional<std::vector<int>> rotation_indices;
};

struct Result {
  double median_ms = -1;
  int runs = 0;
  bool budget_hit = false;
  bool timeout = false;
  std::string verdict = "-";
  int reduced = -1;
  long long table_bytes = -1;
  long rss_kb = -1;
  std::string error;
};

lipmap::BoundaryPolygon to_boundary(const Case& c) {
  lipmap::BoundaryPolygon b;
  for (const auto& q : c.poly) b.vertices.push_back({q.x, q.y});
  b.rotation_indices = c.rotation_indices;
  return b;
}

// The double loop: hubs (-0.05, 0), (0.05, 0), then m points on r = 1 + 0.3 cos(t/2) winding `loops` times
// around them; weakly self-overlapping, turning number loops + 1 (the fan from the first hub has
// R = loops there). Same construction as tests/support (make_double_loop), without its CGAL checks.
Poly double_loop(int loops, int m) {
  Poly p{{-0.05, 0}, {0.05, 0}};
  const double pi = lipmap::testgen::kPi;
  const double ta = pi / 2 + 0.1, tb = pi / 2 + 2 * pi * loops - 0.1;
  for (int k = 0; k < m; ++k) {
    const double t = ta + (tb - ta) * k / (m - 1), r = 1 + 0.3 * std::cos(t / 2);
    p.push_back({r * std::cos(t), r * std::sin(t)});
  }
  return p;
}

Result run_case(const Case& c, int runs, double budget_s) {
  Result r;
  const lipmap::BoundaryPolygon bp = to_boundary(c);
  std::vector<double> ms;
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < runs; ++k) {
    lipmap::CancelToken token;
    token.set_deadline(start + std::chrono::milliseconds((long long)(budget_s * 1000)));
    const auto t0 = std::chrono::steady_clock::now();
    try {
      const lipmap::Classification res = lipmap::classify(bp, &token);
      ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      r.verdict = lipmap::to_string(res.verdict);
      r.reduced = res.stats.reduced_vertices;
      r.table_bytes = (long long)res.stats.table_bytes;
    } catch (const lipmap::Cancelled&) {
      r.timeout = ms.empty();
      r.budget_hit = true;
      break;
    } catch (const std::exception& e) {
      r.error = e.what();
      break;
    }
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > budget_s && k + 1 < runs) {
      r.budget_hit = true;
      break;
    }
  }
  r.runs = (int)ms.size();
  if (!ms.empty()) {
    std::sort(ms.begin(), ms.end());
    r.median_ms = ms.size() % 2 ? ms[ms.size() / 2] : 0.5 * (ms[ms.size() / 2 - 1] + ms[ms.size() / 2]);
  }
  struct rusage ru {};
  getrusage(RUSAGE_SELF, &ru);
  r.rss_kb = ru.ru_maxrss;
  return r;
}

// Runs the case in a child process and reads its result back through a pipe.
Result run_isolated(const Case& c, int runs, double budget_s) {
  int fd[2];
  if (pipe(fd) != 0) return run_case(c, runs, budget_s);
  std::fflush(stdout);
  const pid_t pid = fork();
  if (pid < 0) {
    close(fd[0]);
    close(fd[1]);
    return run_case(c, runs, budget_s);
  }
  if (pid == 0) {
    close(fd[0]);
    const Result r = run_case(c, runs, budget_s);
    char buf[1024];
    std::string err = r.error;
    for (char& ch : err)
      if (ch == '\n' || ch == '\t') ch = ' ';
    const int len = std::snprintf(buf, sizeof buf, "%.6f\t%d\t%d\t%d\t%s\t%d\t%lld\t%ld\t%s\n", r.median_ms, r.runs,
                                  (int)r.budget_hit, (int)r.timeout, r.verdict.c_str(), r.reduced, r.table_bytes,
                                  r.rss_kb, err.substr(0, 300).c_str());
    ssize_t off = 0;
    while (off < len) {
      const ssize_t w = write(fd[1], buf + off, size_t(len - off));
      if (w <= 0) break;
      off += w;
    }
    close(fd[1]);
    _exit(0);
  }
  close(fd[1]);
  std::string text;
  char buf[512];
  ssize_t got;
  while ((got = read(fd[0], buf, sizeof buf)) > 0) text.append(buf, size_t(got));
  close(fd[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  Result r;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || text.empty()) {
    r.error = WIFSIGNALED(status) ? std::string("child killed by signal ") + std::to_string(WTERMSIG(status))
                                  : "child failed";
    return r;
  }
  std::vector<std::string> f;
  size_t pos = 0;
  while (true) {
    const size_t tab = text.find_first_of("\t\n", pos);
    if (tab == std::string::npos) break;
    f.push_back(text.substr(pos, tab - pos));
    pos = tab + 1;
  }
  if (f.size() < 8) {
    r.error = "bad child output";
    return r;
  }
  r.median_ms = std::atof(f[0].c_str());
  r.runs = std::atoi(f[1].c_str());
  r.budget_hit = f[2] == "1";
  r.timeout = f[3] == "1";
  r.verdict = f[4];
  r.reduced = std::atoi(f[5].c_str());
  r.table_bytes = std::atoll(f[6].c_str());
  r.rss_kb = std::atol(f[7].c_str());
  if (f.size() > 8) r.error = f[8];
  return r;
}

std::string human_bytes(long long b) {
  char buf[32];
  if (b < 0) return "-";
  if (b < 10 * 1024) std::snprintf(buf, sizeof buf, "%lld B", b);
  else if (b < 10LL * 1024 * 1024) std::snprintf(buf, sizeof buf, "%.1f KiB", b / 1024.0);
  else std::snprintf(buf, sizeof buf, "%.1f MiB", b / (1024.0 * 1024.0));
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false, curve = false;
  int runs = 5;
  double budget_s = 120;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--quick")) quick = true;
    else if (!std::strcmp(argv[i], "--curve")) curve = true;
    else if (!std::strcmp(argv[i], "--runs") && i + 1 < argc) runs = std::max(1, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--budget-s") && i + 1 < argc) budget_s = std::max(0.1, std::atof(argv[++i]));
    else {
      std::printf("usage: %s [--quick] [--runs N] [--budget-s S]\n", argv[0]);
      return 0;
    }
  }
  if (quick) budget_s = std::min(budget_s, 20.0);

  struct utsname u {};
  uname(&u);
  std::printf("machine: %s %s %s %s, nproc %ld (hardware_concurrency %u)\n", u.sysname, u.nodename, u.release,
              u.machine, sysconf(_SC_NPROCESSORS_ONLN), std::thread::hardware_concurrency());
  std::printf("mode: %s, up to %d runs per case, time budget %.0f s per case\n\n", quick ? "quick" : "full", runs,
              budget_s);

  if (curve) {
    std::printf("%-24s %6s %12s %-24s %8s %12s %12s\n", "case", "n", "ms", "verdict", "reduced", "table", "peak RSS");
    auto row = [&](const Case& c) {
      const Result r = run_isolated(c, 1, budget_s);
      std::printf("%-24s %6zu %12s %-24s %8d %12s %9.1f MiB%s%s\n", c.kind.c_str(), c.poly.size(),
                  r.median_ms >= 0 ? std::to_string((long long)r.median_ms).c_str() : "timeout", r.verdict.c_str(),
                  r.reduced, human_bytes(r.table_bytes).c_str(), r.rss_kb / 1024.0, r.error.empty() ? "" : "  error: ",
                  r.error.c_str());
      std::fflush(stdout);
      return r.median_ms >= 0;
    };
    for (int n : {2000, 8000, 20000}) {
      Rng rng(2000 + (unsigned)n);
      row({"spiral strip 3 turns", n, lipmap::testgen::overlapping_spiral(n, 3, rng), std::nullopt});
    }
    // The costly family: a polygon winding twice around its hub (turning number 3), searched freely; App. C
    // reduces nothing and the table's entries hold turn masks.
    for (int n : {500, 1000, 2000, 3000, 4000, 6000, 8000})
      if (!row({"double loop x2", n, double_loop(2, n - 2), std::nullopt})) break;
    const Case c{"double loop x2", 8000, double_loop(2, 8000 - 2), std::nullopt};
    const lipmap::BoundaryPolygon bp = to_boundary(c);
    lipmap::CancelToken token;
    const auto t0 = std::chrono::steady_clock::now();
    token.set_deadline(t0 + std::chrono::seconds(1));
    try {
      (void)lipmap::classify(bp, &token);
      std::printf("\ncancellation: the 8,000-vertex double loop finished within 1 s (nothing to cancel)\n");
    } catch (const lipmap::Cancelled&) {
      const double late = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() - 1000;
      std::printf("\ncancellation: deadline 1 s into the 8,000-vertex double loop; classify threw %.1f ms after it\n", late);
    }
    return 0;
  }

  std::vector<Case> cases;
  const std::vector<int> simple_sizes = quick ? std::vector<int>{100, 300, 1000} : std::vector<int>{100, 300, 1000, 1500, 3000, 5000};
  const std::vector<int> spiral_sizes = quick ? std::vector<int>{100, 300} : std::vector<int>{100, 300, 1000, 1500};
  const std::vector<double> spiral_turns = quick ? std::vector<double>{2, 3} : std::vector<double>{2, 3, 4};
  for (int n : simple_sizes) {
    Rng rng(1000 + (unsigned)n);
    cases.push_back({"noisy circle", n, lipmap::testgen::noisy_circle(n, 0.05, rng), std::nullopt});
    cases.push_back({"wavy polygon", n, lipmap::testgen::wavy_polygon(n, rng), std::nullopt});
  }
  for (double turns : spiral_turns)
    for (int n : spiral_sizes) {
      Rng rng(2000 + (unsigned)n);
      char kind[64];
      std::snprintf(kind, sizeof kind, "spiral strip %.0f turns", turns);
      cases.push_back({kind, n, lipmap::testgen::overlapping_spiral(n, turns, rng), std::nullopt});
    }
  // Weakly self-overlapping (turning number > 1): free rotation search, and the same with the fan's R given.
  for (int loops : quick ? std::vector<int>{2} : std::vector<int>{2, 3})
    for (int n : quick ? std::vector<int>{300} : std::vector<int>{300, 1000}) {
      const Poly p = double_loop(loops, n - 2);
      std::vector<int> R(p.size(), 0);
      R[0] = loops;
      cases.push_back({"double loop x" + std::to_string(loops), n, p, std::nullopt});
      cases.push_back({"double loop x" + std::to_string(loops) + " R given", n, p, R});
    }

  std::printf("%-24s %6s %12s %5s %-24s %8s %12s %12s\n", "case", "n", "median ms", "runs", "verdict", "reduced",
              "table", "peak RSS");
  for (const Case& c : cases) {
    const Result r = run_isolated(c, runs, budget_s);
    char med[32], rs[16], rss[32];
    if (r.median_ms >= 0) std::snprintf(med, sizeof med, "%.3f", r.median_ms);
    else std::snprintf(med, sizeof med, "%s", r.timeout ? "timeout" : "-");
    std::snprintf(rs, sizeof rs, "%d%s", r.runs, r.budget_hit ? "*" : "");
    std::snprintf(rss, sizeof rss, "%.1f MiB", r.rss_kb / 1024.0);
    std::printf("%-24s %6zu %12s %5s %-24s %8d %12s %12s%s%s\n", c.kind.c_str(), c.poly.size(), med, rs,
                r.verdict.c_str(), r.reduced, human_bytes(r.table_bytes).c_str(), rss,
                r.error.empty() ? "" : "  error: ", r.error.c_str());
    std::fflush(stdout);
  }
  std::printf("\n* = stopped by the time budget before all runs were done; timeout = no run finished in it.\n");
  return 0;
}
