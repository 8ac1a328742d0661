// App. C: clip as many ears as is safe, so the cubic table runs on a small polygon. A uniform grid over
// the edges makes each ear test look only at nearby edges; it is a filter in front of exact tests only.
#include "engine/detail/ear_reduction.h"

#include <algorithm>
#include <cmath>
#include <queue>

namespace lipmap::detail {
namespace {

// Edges bucketed by the grid cells their bounding boxes cover. Cells come from one monotone float
// function of the coordinates, so boxes that overlap exactly always share a cell: no intersection is missed.
class EdgeGrid {
public:
  EdgeGrid(const std::vector<Pt>& p) {
    double x0 = p[0].x(), x1 = x0, y0 = p[0].y(), y1 = y0;
    for (const Pt& q : p) {
      x0 = std::min(x0, q.x()); x1 = std::max(x1, q.x());
      y0 = std::min(y0, q.y()); y1 = std::max(y1, q.y());
    }
    x0_ = x0; y0_ = y0;
    const double w = x1 - x0, h = y1 - y0, n = static_cast<double>(p.size());
    // About one edge per cell, and never more than about 3n cells: a thin polygon (the image of a refined
    // face is often a sliver) would otherwise get thousands of empty cells to allocate and scan.
    double cell = std::sqrt(std::max(w * h, 1e-300) / n);
    cell = std::max({cell, w / n, h / n});
    if (p.size() <= kSmall) cell = std::max(w, h) * 2;  // brute force is cheaper than any grid
    // A subnormal cell has an infinite inverse: every offset would land in the last cell and each edge cover
    // all kMaxCells^2 of them (2 GB and 20 s for a triangle of subnormal coordinates, found by the fuzzer).
    if (cell > 0 && std::isfinite(cell) && std::isfinite(1 / cell)) {
      inv_ = 1 / cell;
      nx_ = 1 + cell_index(w * inv_, kMaxCells);
      ny_ = 1 + cell_index(h * inv_, kMaxCells);
    }  // else (a degenerate or overflowing extent, e.g. coordinates near 1e308): one cell, brute force
    cells_.resize(static_cast<std::size_t>(nx_) * ny_);
  }

  void insert(const Pt& a, const Pt& b, int from, int to) {
    visit(a, b, [&](std::vector<Edge>& cell) { cell.push_back({from, to}); return false; });
  }

  // Calls f(from, to) for every live edge whose cells meet the box of the three points (an edge may come
  // up once per cell it covers) until f returns true. Entries that `live` rejects are dropped on the way.
  template <class Live, class F>
  bool any_near(const Pt& a, const Pt& b, const Pt& c, Live&& live, F&& f) {
    const int cx0 = cx(std::min({a.x(), b.x(), c.x()})), cx1 = cx(std::max({a.x(), b.x(), c.x()}));
    const int cy0 = cy(std::min({a.y(), b.y(), c.y()})), cy1 = cy(std::max({a.y(), b.y(), c.y()}));
    for (int y = cy0; y <= cy1; ++y) {
      for (int x = cx0; x <= cx1; ++x) {
        std::vector<Edge>& cell = cells_[static_cast<std::size_t>(y) * nx_ + x];
        for (std::size_t e = 0; e < cell.size();) {
          if (!live(cell[e].from, cell[e].to)) {
            cell[e] = cell.back();
            cell.pop_back();
            continue;
          }
          if (f(cell[e].from, cell[e].to)) return true;
          ++e;
        }
      }
    }
    return false;
  }

private:
  // Up to kSmall vertices, one cell (a scan of every edge, most rejected by their boxes): refine's image
  // polygons (about 30 vertices, tested a million times on the maze) spent a tenth of their time allocating cells.
  static constexpr std::size_t kSmall = 64;
  static constexpr int kMaxCells = 4096;
  struct Edge { int from, to; };
  // A position in cell units to a cell index in [0, cells - 1], clamped in floating point before the cast:
  // casting a value beyond int's range, or the NaN of an infinite offset times a zero scale, is undefined.
  static int cell_index(double units, int cells) {
    if (!(units >= 0)) return 0;
    if (units >= cells - 1) return cells - 1;
    return static_cast<int>(units);
  }
  int cx(double x) const { return cell_index(std::floor((x - x0_) * inv_), nx_); }
  int cy(double y) const { return cell_index(std::floor((y - y0_) * inv_), ny_); }
  template <class F>
  void visit(const Pt& a, const Pt& b, F&& f) {
    const int cx0 = cx(std::min(a.x(), b.x())), cx1 = cx(std::max(a.x(), b.x()));
    const int cy0 = cy(std::min(a.y(), b.y())), cy1 = cy(std::max(a.y(), b.y()));
    for (int y = cy0; y <= cy1; ++y)
      for (int x = cx0; x <= cx1; ++x) f(cells_[static_cast<std::size_t>(y) * nx_ + x]);
  }

  double x0_ = 0, y0_ = 0, inv_ = 0;
  int nx_ = 1, ny_ = 1;
  std::vector<std::vector<Edge>> cells_;
};

// Does segment (s, t) meet the closed, counterclockwise triangle (a, b, c)? Two compact convex sets are
// disjoint exactly when a line parallel to one of their sides separates them strictly, so orientation
// signs alone decide it (no constructions).
bool segment_meets_triangle(const Pt& s, const Pt& t, const Pt& a, const Pt& b, const Pt& c) {
  // Boxes apart (strictly: comparisons of the doubles themselves, exact): disjoint, without a predicate.
  if (std::max(s.x(), t.x()) < std::min({a.x(), b.x(), c.x()}) ||
      std::min(s.x(), t.x()) > std::max({a.x(), b.x(), c.x()}) ||
      std::max(s.y(), t.y()) < std::min({a.y(), b.y(), c.y()}) ||
      std::min(s.y(), t.y()) > std::max({a.y(), b.y(), c.y()}))
    return false;
  const Pt* corner[3] = {&a, &b, &c};
  for (int i = 0; i < 3; ++i) {
    const Pt &p = *corner[i], &q = *corner[(i + 1) % 3];
    if (orient(p, q, s) < 0 && orient(p, q, t) < 0) return false;
  }
  const int oa = orient(s, t, a), ob = orient(s, t, b), oc = orient(s, t, c);
  if ((oa > 0 && ob > 0 && oc > 0) || (oa < 0 && ob < 0 && oc < 0)) return false;
  return true;
}

class EarClipper {
public:
  EarClipper(const std::vector<Pt>& p, std::vector<int> turns, const std::function<bool(int, int, int)>* allowed)
      : allowed_(allowed), p_(p), n_(static_cast<int>(p.size())), turns_(std::move(turns)), next_(n_), prev_(n_),
        alive_(n_, 1), seen_(n_, -1), version_(n_, 0), grid_(p) {
    for (int v = 0; v < n_; ++v) {
      next_[v] = (v + 1) % n_;
      prev_[v] = (v + n_ - 1) % n_;
      grid_.insert(p_[v], p_[next_[v]], v, next_[v]);
    }
    size_ = n_;
  }

  EarReduction run(const CancelToken* cancel) {
    // Smallest ears first (by the length of the chord they add): triangles stay local, so the grid
    // queries stay small, and a blocked vertex is tested again only when a neighbour was clipped.
    // Removing edges can also free ears elsewhere, hence a few whole passes while they still help.
    for (int pass = 0; pass < 4 && size_ > 3; ++pass) {
      const int before = size_;
      for (int v = 0; v < n_; ++v)
        if (alive_[v]) enqueue(v);
      int since_check = 0;
      while (!queue_.empty() && size_ > 3) {
        if (++since_check == 1024) { check_cancel(cancel); since_check = 0; }
        const Candidate top = queue_.top();
        queue_.pop();
        if (!alive_[top.v] || top.version != version_[top.v] || !clip_if_ear(top.v)) continue;
        enqueue(prev_[top.v]);
        enqueue(next_[top.v]);
      }
      queue_ = {};
      if (size_ == before) break;
    }
    EarReduction out;
    out.ears = std::move(ears_);
    int start = 0;
    while (!alive_[start]) ++start;
    int v = start;
    do {
      out.remaining.push_back(v);
      out.turns.push_back(turns_[v]);
      v = next_[v];
    } while (v != start);
    return out;
  }

private:
  struct Candidate {
    double chord2;
    int v, version;
    bool operator<(const Candidate& o) const { return chord2 > o.chord2; }  // min-heap on chord length
  };

  void enqueue(int v) {
    const Pt &a = p_[prev_[v]], &b = p_[next_[v]];
    const double dx = a.x() - b.x(), dy = a.y() - b.y();
    queue_.push({dx * dx + dy * dy, v, ++version_[v]});
  }

  // Tests the ear at v and clips it when it is safe (see ear_reduction.h).
  bool clip_if_ear(int v) {
    const int a = prev_[v], b = next_[v];
    if (turns_[v] != 0) return false;
    if (allowed_ && !(*allowed_)(a, v, b)) return false;
    const Pt &pa = p_[a], &pv = p_[v], &pb = p_[b];
    if (orient(pa, pv, pb) <= 0) return false;
    // Remaining prescribed angles at a and b: the ear takes the sweep v -> b at a and a -> v at b.
    const int c = next_[b], d = prev_[a];
    const int turns_a = turns_[a] - extra_turn(pa, pv, pb, p_[d]);
    const int turns_b = turns_[b] - extra_turn(pb, p_[c], pa, pv);
    if (turns_a < 0 || (turns_a == 0 && sector(pa, pb, p_[d]) == 0)) return false;
    if (turns_b < 0 || (turns_b == 0 && sector(pb, p_[c], pa) == 0)) return false;
    if (!ear_is_empty(a, v, b)) return false;

    ears_.push_back({a, v, b});
    alive_[v] = 0;
    next_[a] = b;
    prev_[b] = a;
    turns_[a] = turns_a;
    turns_[b] = turns_b;
    grid_.insert(pa, pb, a, b);
    --size_;
    return true;
  }

  // The closed triangle (a, v, b) meets the current polygon only in the edges (a, v) and (v, b), and
  // in the single points a and b of the edges arriving at a and leaving b.
  bool ear_is_empty(int a, int v, int b) {
    const Pt &pa = p_[a], &pv = p_[v], &pb = p_[b];
    ++query_;
    auto live = [&](int from, int to) { return alive_[from] && next_[from] == to; };  // else a clipped edge
    const bool blocked = grid_.any_near(pa, pv, pb, live, [&](int from, int to) {
      if (seen_[from] == query_) return false;
      seen_[from] = query_;
      if (from == a || from == v) return false;  // the ear's own edges
      // The edge leaving b must start outside the ear's corner at b (sweep a -> v), the edge arriving
      // at a outside the corner at a (sweep v -> b); the ear is convex, so it then never comes back.
      if (from == b) return !sweeps_before(pb, pa, pv, p_[to]);
      if (to == a) return !sweeps_before(pa, pv, pb, p_[from]);
      return segment_meets_triangle(p_[from], p_[to], pa, pv, pb);
    });
    return !blocked;
  }

  const std::function<bool(int, int, int)>* allowed_;
  const std::vector<Pt>& p_;
  int n_, size_ = 0, query_ = 0;
  std::vector<int> turns_, next_, prev_;
  std::vector<char> alive_;
  std::vector<int> seen_, version_;
  EdgeGrid grid_;
  std::priority_queue<Candidate> queue_;
  std::vector<Triangle> ears_;
};

}  // namespace

EarReduction clip_ears(const std::vector<Pt>& polygon, std::vector<int> turns, const CancelToken* cancel,
                       const std::function<bool(int, int, int)>* allowed) {
  EarClipper clipper(polygon, std::move(turns), allowed);
  return clipper.run(cancel);
}

}  // namespace lipmap::detail
