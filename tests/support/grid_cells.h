// The triangles of a grid of nx x ny square cells, shared by the tests that build grid meshes (no engine
// code): vertex (i, j), 0 <= i <= nx, 0 <= j <= ny, is numbered j * (nx + 1) + i.
#pragma once

#include <array>
#include <functional>
#include <vector>

namespace lipmap::testgen {

// Cell (i, j) has corners a = (i, j), b = (i + 1, j), c = (i + 1, j + 1), d = (i, j + 1) and is split by the
// diagonal a-c into (a, b, c), (a, c, d) when diagonal_ac(i, j), else by b-d into (a, b, d), (b, c, d): both
// counterclockwise when i runs along x and j along y. diagonal_ac is called once per cell, j by j and i by i
// within a row (callers draw it from a random stream); the triangles come in that order.
inline std::vector<std::array<int, 3>> grid_triangles(int nx, int ny, const std::function<bool(int, int)>& diagonal_ac) {
  std::vector<std::array<int, 3>> t;
  t.reserve(size_t(2) * size_t(nx > 0 ? nx : 0) * size_t(ny > 0 ? ny : 0));
  auto id = [nx](int i, int j) { return j * (nx + 1) + i; };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      if (diagonal_ac(i, j)) {
        t.push_back({a, b, c});
        t.push_back({a, c, d});
      } else {
        t.push_back({a, b, d});
        t.push_back({b, c, d});
      }
    }
  return t;
}

// The border of the grid as a vertex loop from vertex 0 with the grid on its left (counterclockwise when i
// runs along x and j along y): along j = 0, up i = nx, back along j = ny, down i = 0.
inline std::vector<int> grid_boundary(int nx, int ny) {
  std::vector<int> loop;
  auto id = [nx](int i, int j) { return j * (nx + 1) + i; };
  for (int i = 0; i < nx; ++i) loop.push_back(id(i, 0));
  for (int j = 0; j < ny; ++j) loop.push_back(id(nx, j));
  for (int i = nx; i > 0; --i) loop.push_back(id(i, ny));
  for (int j = ny; j > 0; --j) loop.push_back(id(0, j));
  return loop;
}

// The diagonal pattern of alternating cells: a-c where i + j is odd.
inline bool alternating_diagonal(int i, int j) { return (i + j) % 2 != 0; }

}  // namespace lipmap::testgen
