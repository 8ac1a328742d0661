#include "engine/flip_check.h"

#include <cassert>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

namespace lipmap {
namespace {

using Epick = CGAL::Exact_predicates_inexact_constructions_kernel;

inline bool positive(const std::vector<Point2>& uv, const Triangle& t) {
  assert(t[0] >= 0 && t[1] >= 0 && t[2] >= 0);
  const Point2& a = uv[static_cast<std::size_t>(t[0])];
  const Point2& b = uv[static_cast<std::size_t>(t[1])];
  const Point2& c = uv[static_cast<std::size_t>(t[2])];
  return CGAL::orientation(Epick::Point_2(a.x, a.y), Epick::Point_2(b.x, b.y), Epick::Point_2(c.x, c.y)) ==
         CGAL::LEFT_TURN;
}

}  // namespace

int orientation_sign(const Point2& a, const Point2& b, const Point2& c) {
  return static_cast<int>(
      CGAL::orientation(Epick::Point_2(a.x, a.y), Epick::Point_2(b.x, b.y), Epick::Point_2(c.x, c.y)));
}

int count_non_positive(const std::vector<Point2>& uv, const std::vector<Triangle>& faces) {
  int count = 0;
  for (const Triangle& t : faces) count += positive(uv, t) ? 0 : 1;
  return count;
}

std::vector<int> non_positive_faces(const std::vector<Point2>& uv, const std::vector<Triangle>& faces) {
  std::vector<int> out;
  for (std::size_t f = 0; f < faces.size(); ++f)
    if (!positive(uv, faces[f])) out.push_back(static_cast<int>(f));
  return out;
}

}  // namespace lipmap
