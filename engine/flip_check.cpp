// Exact orientation checks through the engine's one exact module (engine/detail/exact_predicates.h).
#include "engine/flip_check.h"

#include <cassert>

#include "engine/detail/exact_predicates.h"

namespace lipmap {
namespace {

inline bool positive(const std::vector<Point2>& uv, const Triangle& t) {
  assert(t[0] >= 0 && t[1] >= 0 && t[2] >= 0);
  return detail::orient(uv[static_cast<std::size_t>(t[0])], uv[static_cast<std::size_t>(t[1])],
                        uv[static_cast<std::size_t>(t[2])]) > 0;
}

}  // namespace

int orientation_sign(const Point2& a, const Point2& b, const Point2& c) { return detail::orient(a, b, c); }

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
