// Plain value types shared by the stages. Exact predicates live in the .cpp files (CGAL stays there).
#pragma once

#include <array>
#include <vector>

namespace lipmap {

struct Point2 {
  double x = 0, y = 0;
  friend bool operator==(const Point2& a, const Point2& b) { return a.x == b.x && a.y == b.y; }
  friend bool operator!=(const Point2& a, const Point2& b) { return !(a == b); }
};

struct Point3 {
  double x = 0, y = 0, z = 0;
  friend bool operator==(const Point3& a, const Point3& b) { return a.x == b.x && a.y == b.y && a.z == b.z; }
};

using Triangle = std::array<int, 3>;

}  // namespace lipmap
