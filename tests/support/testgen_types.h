// Plain types shared by the test-side polygon generators and the independent triangulation checker
// (no engine code, no CGAL).
#pragma once

#include <array>
#include <vector>

namespace lipmap::testgen {
struct Pt {
  double x = 0, y = 0;
  friend bool operator==(const Pt& a, const Pt& b) { return a.x == b.x && a.y == b.y; }
  friend bool operator!=(const Pt& a, const Pt& b) { return !(a == b); }
};
using Poly = std::vector<Pt>;
using Tri = std::array<int, 3>;
constexpr long double kPiL = 3.141592653589793238462643383279502884L;
constexpr long double kTwoPiL = 2 * kPiL;
}  // namespace lipmap::testgen
