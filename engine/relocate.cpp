// Vertex relocation (see relocate.h). For a tangled vertex v the aim in uv is the centroid of the kernel of
// its image link polygon (where every triangle of the one-ring is positive); when that kernel is empty no
// position helps and v stays. The disk point reaching it is found by Newton steps on the piecewise-affine
// h_t^-1, halved while they would leave v's disk one-ring kernel. Only exact orientation tests on the final
// doubles decide whether a move is kept.
#include "engine/relocate.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

#include "engine/detail/disk_walk.h"
#include "engine/detail/exact_predicates.h"
#include "engine/flip_check.h"

namespace lipmap {
namespace {

using detail::Pt;

using detail::pt;

// The kernel of a counterclockwise polygon (intersection of the left half-planes of its edges), clipped
// from a large box in double, and its centroid. Only a guess for the search; the caller checks exactly.
std::optional<Point2> kernel_centroid(const std::vector<Point2>& polygon) {
  double lo = polygon[0].x, hi = lo;
  for (const Point2& p : polygon) lo = std::min({lo, p.x, p.y}), hi = std::max({hi, p.x, p.y});
  const double pad = 2 * (hi - lo) + 1;
  std::vector<Point2> kernel = {{lo - pad, lo - pad}, {hi + pad, lo - pad}, {hi + pad, hi + pad}, {lo - pad, hi + pad}};
  auto side = [](const Point2& a, const Point2& b, const Point2& p) {
    return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
  };
  for (std::size_t i = 0; i < polygon.size() && kernel.size() >= 3; ++i) {
    const Point2 &a = polygon[i], &b = polygon[(i + 1) % polygon.size()];
    std::vector<Point2> clipped;
    for (std::size_t j = 0; j < kernel.size(); ++j) {
      const Point2 &p = kernel[j], &q = kernel[(j + 1) % kernel.size()];
      const double sp = side(a, b, p), sq = side(a, b, q);
      if (sp > 0) clipped.push_back(p);
      if ((sp > 0) != (sq > 0)) {
        const double t = sp / (sp - sq);
        clipped.push_back({p.x + t * (q.x - p.x), p.y + t * (q.y - p.y)});
      }
    }
    kernel = std::move(clipped);
  }
  if (kernel.size() < 3) return std::nullopt;
  double area = 0, cx = 0, cy = 0;
  for (std::size_t j = 0; j < kernel.size(); ++j) {
    const Point2 &p = kernel[j], &q = kernel[(j + 1) % kernel.size()];
    const double c = p.x * q.y - q.x * p.y;
    area += c;
    cx += (p.x + q.x) * c;
    cy += (p.y + q.y) * c;
  }
  if (!(area > 0)) return std::nullopt;
  return Point2{cx / (3 * area), cy / (3 * area)};
}

class Relocator {
public:
  Relocator(const DiskMesh& source, const std::vector<int>& loop, std::vector<Point2>& disk, Composition& composition,
            const TargetMesh& target)
      : source_(source), disk_(disk), uv_(composition.uv), face_(composition.target_face), target_(target),
        walk_(*composition.walk), boundary_(source.vertices.size(), 0), was_moved_(source.vertices.size(), 0) {
    for (int v : loop) boundary_[v] = 1;
  }

  Relocation run(const CancelToken* cancel) {
    Relocation out;
    out.flipped_before = count_non_positive(uv_, source_.faces);
    if (out.flipped_before == 0) return out;  // nothing is tangled: the sweeps would move nothing
    // Every move lowers the number of non-positive triangles (only v's own change), and a move can free its
    // neighbours' moves, so a few sweeps over the vertices still next to a flip settle it.
    for (int sweep = 0; sweep < kSweeps; ++sweep) {
      check_cancel(cancel);
      int moved = 0;
      for (int v = 0; v < static_cast<int>(uv_.size()); ++v) {
        if (boundary_[v] || !tangled(v) || !move(v)) continue;
        ++moved;
        if (!was_moved_[v]) { was_moved_[v] = 1; ++out.moved; }
      }
      if (moved == 0) break;
    }
    out.flipped_after = count_non_positive(uv_, source_.faces);
    return out;
  }

private:
  static constexpr int kSweeps = 8, kNewtonSteps = 16, kHalvings = 10;

  using Corner = detail::FanCorner;

  // v's corner in each face (v, next, prev), with the image rays towards next and prev.
  std::vector<Corner> corners(int v) const {
    std::vector<Corner> out;
    const MeshTopology& mesh = source_.topology;
    for (int h : mesh.fan(v)) {
      const int next = mesh.to(h), prev = mesh.from(MeshTopology::prev(h));
      out.push_back({next, prev, pt(uv_[next]), pt(uv_[prev])});
    }
    return out;
  }

  bool positive(const Triangle& t) const {
    return detail::orient(pt(uv_[t[0]]), pt(uv_[t[1]]), pt(uv_[t[2]])) > 0;
  }

  bool tangled(int v) const {
    for (int h : source_.topology.fan(v))
      if (!positive(source_.faces[MeshTopology::face_of(h)])) return true;
    return false;
  }

  // Every triangle (q, next, prev) strictly positive in the given positions.
  template <class Position>
  static bool fan_positive(const Pt& q, const std::vector<Corner>& fan, Position&& at) {
    for (const Corner& c : fan)
      if (detail::orient(q, at(c.next), at(c.prev)) <= 0) return false;
    return true;
  }

  // Aims in uv: the centroid of the image link's kernel, where the whole one-ring is positive; when the
  // kernel is empty (the neighbours are tangled too), the centroid of the link's vertices, kept only if it
  // leaves fewer non-positive triangles around v. Each kept move lowers the number of flips, so the sweeps
  // end; what they cannot untangle is refine's.
  bool move(int v) {
    const std::vector<Corner> fan = corners(v);
    std::vector<Point2> link;  // the image link polygon, counterclockwise: next -> prev around the fan
    int at = fan[0].next;
    for (std::size_t step = 0; step < fan.size(); ++step) {
      auto it = std::find_if(fan.begin(), fan.end(), [&](const Corner& c) { return c.next == at; });
      if (it == fan.end()) return false;
      link.push_back(uv_[at]);
      at = it->prev;
    }
    if (const std::optional<Point2> aim = kernel_centroid(link)) return move_towards(v, fan, *aim, 0);
    Point2 mean{0, 0};
    for (const Point2& p : link) mean = {mean.x + p.x / link.size(), mean.y + p.y / link.size()};
    return move_towards(v, fan, mean, non_positive(pt(uv_[v]), fan) - 1);
  }

  int non_positive(const Pt& q, const std::vector<Corner>& fan) const {
    int n = 0;
    for (const Corner& c : fan) n += detail::orient(q, c.from, c.to) > 0 ? 0 : 1;
    return n;
  }

  // Newton steps x += D U^-1 (aim - f(x)) on the affine piece of h_t^-1 in the target face containing x,
  // each halved while it would leave v's disk one-ring kernel, until at most `allowed` triangles of the
  // image one-ring are non-positive (and, with none, the one-ring winds once).
  bool move_towards(int v, const std::vector<Corner>& fan, const Point2& aim, int allowed) {
    if (allowed < 0) return false;
    const auto disk_at = [&](int w) { return pt(disk_[w]); };
    Point2 x = disk_[v];
    int face = face_[v];
    for (int step = 0; step < kNewtonSteps; ++step) {
      const Point2 image = walk_.target_point(pt(x), face);
      const std::optional<Point2> dx = newton_step(face, {aim.x - image.x, aim.y - image.y});
      if (!dx) return false;
      double s = 1;
      Point2 next{};
      bool inside = false;
      for (int h = 0; h < kHalvings && !inside; ++h, s *= 0.5) {
        next = {x.x + s * dx->x, x.y + s * dx->y};
        inside = fan_positive(pt(next), fan, disk_at);
      }
      if (!inside) return false;
      x = next;
      face = walk_.locate(pt(x), face);
      const Point2 moved = walk_.target_point(pt(x), face);
      const int bad = non_positive(pt(moved), fan);
      if (bad <= allowed && (bad > 0 || detail::fan_turns(pt(moved), fan) == 1)) {
        disk_[v] = x;
        uv_[v] = moved;
        face_[v] = face;
        return true;
      }
    }
    return false;
  }

  std::optional<Point2> newton_step(int face, const Point2& r) const {
    const Triangle& t = walk_.face(face);
    const Pt &d0 = walk_.disk_point(t[0]), &d1 = walk_.disk_point(t[1]), &d2 = walk_.disk_point(t[2]);
    const Point2 &u0 = target_.vertices[t[0]], &u1 = target_.vertices[t[1]], &u2 = target_.vertices[t[2]];
    const double a = u1.x - u0.x, b = u2.x - u0.x, c = u1.y - u0.y, d = u2.y - u0.y;
    const double det = a * d - b * c;
    if (!(std::abs(det) > 0) || !std::isfinite(det)) return std::nullopt;
    const double p = (d * r.x - b * r.y) / det, q = (-c * r.x + a * r.y) / det;  // barycentric increments
    const Point2 out{p * (d1.x() - d0.x()) + q * (d2.x() - d0.x()), p * (d1.y() - d0.y()) + q * (d2.y() - d0.y())};
    if (!std::isfinite(out.x) || !std::isfinite(out.y)) return std::nullopt;
    return out;
  }

  const DiskMesh& source_;
  std::vector<Point2>& disk_;
  std::vector<Point2>& uv_;
  std::vector<int>& face_;
  const TargetMesh& target_;
  const detail::DiskWalk& walk_;
  std::vector<char> boundary_, was_moved_;
};

}  // namespace

Relocation relocate_tangled_vertices(const DiskMesh& source, const std::vector<int>& loop,
                                     std::vector<Point2>& source_disk, Composition& composition,
                                     const TargetMesh& target, const CancelToken* cancel) {
  Relocator relocator(source, loop, source_disk, composition, target);
  return relocator.run(cancel);
}

}  // namespace lipmap
