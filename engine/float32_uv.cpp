// Float32 texture coordinates of a uv map (see float32_uv.h). Every decision is an exact orientation test
// on the stored values or an exact turn count (engine/detail/exact_predicates.h, paper App. B).
#include "engine/float32_uv.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <utility>

#include "engine/detail/exact_predicates.h"

namespace lipmap {
namespace {

using detail::Pt;

using detail::pt;

// The stored (s, t) and the read-back (s, 1 - t) of every vertex.
struct Stored {
  std::vector<Point2> st, back;

  void set(std::size_t v, float s, float t) {
    st[v] = {s, t};
    back[v] = {s, 1.0 - static_cast<double>(t)};
  }
  // Orientation in the read-back plane (s, 1 - t).
  int back_orientation(const Triangle& f) const {
    return detail::orient(pt(back[f[0]]), pt(back[f[1]]), pt(back[f[2]]));
  }
  bool valid(const Triangle& f) const {
    return detail::orient(pt(st[f[0]]), pt(st[f[1]]), pt(st[f[2]])) == -1 && back_orientation(f) == 1;
  }
};

float step(float x, int n) {
  for (; n > 0; --n) x = std::nextafter(x, std::numeric_limits<float>::infinity());
  for (; n < 0; ++n) x = std::nextafter(x, -std::numeric_limits<float>::infinity());
  return x;
}

// The moves a vertex may make, smallest first: one coordinate by one ulp, then both, then two ulps.
std::vector<std::pair<int, int>> moves() {
  std::vector<std::pair<int, int>> offsets;
  for (int ds = -2; ds <= 2; ++ds)
    for (int dt = -2; dt <= 2; ++dt)
      if (ds || dt) offsets.push_back({ds, dt});
  std::stable_sort(offsets.begin(), offsets.end(), [](const auto& x, const auto& y) {
    const auto cost = [](const std::pair<int, int>& o) {
      return std::max(std::abs(o.first), std::abs(o.second)) * 10 + std::abs(o.first) + std::abs(o.second);
    };
    return cost(x) < cost(y);
  });
  return offsets;
}

// Vertices on an edge that only one face uses.
std::vector<char> boundary_vertices(const std::vector<Triangle>& faces, std::size_t nv) {
  std::vector<std::uint64_t> edges;
  edges.reserve(faces.size() * 3);
  for (const Triangle& f : faces)
    for (int c = 0; c < 3; ++c) {
      const auto a = static_cast<std::uint32_t>(std::min(f[c], f[(c + 1) % 3]));
      const auto b = static_cast<std::uint32_t>(std::max(f[c], f[(c + 1) % 3]));
      edges.push_back(static_cast<std::uint64_t>(a) << 32 | b);
    }
  std::sort(edges.begin(), edges.end());
  std::vector<char> boundary(nv, 0);
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i == 1) boundary[edges[i] >> 32] = boundary[edges[i] & 0xffffffffu] = 1;
    i = j;
  }
  return boundary;
}

// Moves interior corners of invalid faces (see float32_uv.h); returns the number of vertices moved.
std::size_t repair(const std::vector<Triangle>& faces, const std::vector<std::vector<int>>& faces_of,
                   const std::vector<char>& boundary, Stored& s) {
  std::vector<int> bad;
  for (std::size_t f = 0; f < faces.size(); ++f)
    if (!s.valid(faces[f])) bad.push_back(static_cast<int>(f));
  if (bad.empty()) return 0;
  std::vector<char> moved(s.st.size(), 0);
  const std::vector<std::pair<int, int>> offsets = moves();
  for (int round = 0; round < 4 && !bad.empty(); ++round) {
    for (int f : bad) {
      if (s.valid(faces[f])) continue;
      for (int v : faces[f]) {
        if (boundary[v]) continue;
        const Point2 st0 = s.st[v], back0 = s.back[v];
        bool fixed = false;
        for (const auto& [ds, dt] : offsets) {
          s.set(v, step(static_cast<float>(st0.x), ds), step(static_cast<float>(st0.y), dt));
          fixed = std::all_of(faces_of[v].begin(), faces_of[v].end(), [&](int g) { return s.valid(faces[g]); });
          if (fixed) break;
        }
        if (fixed) {
          moved[v] = 1;
          break;
        }
        s.st[v] = st0;
        s.back[v] = back0;
      }
    }
    std::vector<int> still;
    for (int f : bad)
      if (!s.valid(faces[f])) still.push_back(f);
    bad.swap(still);
  }
  return static_cast<std::size_t>(std::count(moved.begin(), moved.end(), 1));
}

}  // namespace

// GCC 12's SLP vectorizer (-O2 and up) was seen to drop the double -> float -> double round trip of two
// neighbouring values ({double(float(a)), double(float(b))} compiled to no conversion at all); the checks
// must see exactly the stored floats, so the float goes through memory.
float to_float32(double x) {
  volatile float f = static_cast<float>(x);
  return f;
}

bool float32_face_valid(const Point2& a, const Point2& b, const Point2& c) {
  Stored s{std::vector<Point2>(3), std::vector<Point2>(3)};
  const Point2* corners[3] = {&a, &b, &c};
  for (std::size_t v = 0; v < 3; ++v) s.set(v, to_float32(corners[v]->x), to_float32(1.0 - corners[v]->y));
  return s.valid({0, 1, 2});
}

bool float32_face_robust(const Point2& a, const Point2& b, const Point2& c) {
  const double scale = std::max({std::abs(a.x), std::abs(a.y), std::abs(b.x), std::abs(b.y), std::abs(c.x),
                                 std::abs(c.y), std::abs(1.0 - a.y), std::abs(1.0 - b.y),
                                 std::abs(1.0 - c.y)});
  const double half_ulp = std::ldexp(scale, -24);  // float32 rounding moves each coordinate by at most this
  const double area2 = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
  const double perimeter = std::hypot(b.x - a.x, b.y - a.y) + std::hypot(c.x - b.x, c.y - b.y) +
                           std::hypot(a.x - c.x, a.y - c.y);
  // A corner moved by at most sqrt(2) half_ulp changes the doubled area by at most that times its opposite edge.
  return area2 > 2 * std::sqrt(2.0) * half_ulp * perimeter;
}

Float32Uv float32_texcoords(const std::vector<Point2>& uv, const std::vector<Triangle>& faces) {
  const std::size_t nv = uv.size();
  Stored s{std::vector<Point2>(nv), std::vector<Point2>(nv)};
  for (std::size_t v = 0; v < nv; ++v) s.set(v, to_float32(uv[v].x), to_float32(1.0 - uv[v].y));
  std::vector<std::vector<int>> faces_of(nv);
  for (std::size_t f = 0; f < faces.size(); ++f)
    for (int v : faces[f]) faces_of[v].push_back(static_cast<int>(f));
  const std::vector<char> boundary = boundary_vertices(faces, nv);

  Float32Uv out;
  out.adjusted = repair(faces, faces_of, boundary, s);
  for (std::size_t f = 0; f < faces.size() && out.bad_face < 0; ++f)
    if (!s.valid(faces[f])) {
      out.bad_face = static_cast<int>(f);
      out.bad_face_orientation = s.back_orientation(faces[f]);
    }
  // Positive triangles can still wind twice around a vertex (paper Fig. 1a): count the turns exactly.
  for (std::size_t v = 0; v < nv && out.ok(); ++v) {
    if (boundary[v]) continue;  // a vertex no face uses has no ring: 0 turns
    std::vector<detail::FanCorner> fan;
    for (int f : faces_of[v]) {
      const Triangle& t = faces[f];
      const int c = t[0] == static_cast<int>(v) ? 0 : t[1] == static_cast<int>(v) ? 1 : 2;
      const int next = t[(c + 1) % 3], prev = t[(c + 2) % 3];
      fan.push_back({next, prev, pt(s.back[next]), pt(s.back[prev])});
    }
    const int turns = detail::fan_turns(pt(s.back[v]), fan);
    if (turns != 1) {
      out.bad_vertex = static_cast<int>(v);
      out.bad_vertex_turns = turns;
    }
  }
  out.st = std::move(s.st);
  return out;
}

}  // namespace lipmap
