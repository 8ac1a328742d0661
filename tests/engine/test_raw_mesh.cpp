// engine/raw_mesh.h: FaceList, the flat list of faces as they arrive, against the obvious model (a vector of
// vectors) over many random edits: every face, the size and the flat indices agree after each one.
#include <gtest/gtest.h>

#include <random>
#include <utility>
#include <vector>

#include "engine/raw_mesh.h"

namespace {

using lipmap::FaceList;
using Model = std::vector<std::vector<long long>>;

void expect_same(const FaceList& list, const Model& model, int step) {
  ASSERT_EQ(list.size(), model.size()) << "step " << step;
  ASSERT_EQ(list.empty(), model.empty()) << "step " << step;
  std::vector<long long> flat;
  for (std::size_t f = 0; f < model.size(); ++f) {
    ASSERT_EQ(std::vector<long long>(list[f]), model[f]) << "face " << f << ", step " << step;
    flat.insert(flat.end(), model[f].begin(), model[f].end());
  }
  ASSERT_EQ(list.indices(), flat) << "step " << step;
  std::size_t f = 0;
  for (const auto& face : list) ASSERT_TRUE(face == model[f++]) << "iteration, step " << step;
  ASSERT_EQ(f, model.size());
  ASSERT_TRUE(list == model);
}

std::vector<long long> random_face(std::mt19937_64& rng) {
  std::vector<long long> face(rng() % 6);  // 0 to 5 indices: empty faces and quads too
  for (long long& v : face) v = static_cast<long long>(rng() % 2001) - 1000;
  return face;
}

TEST(FaceList, EveryEditAgreesWithAVectorOfVectors) {
  std::mt19937_64 rng(5);
  for (int round = 0; round < 50; ++round) {
    FaceList list;
    Model model;
    for (int step = 0; step < 200; ++step) {
      const std::size_t n = model.size();
      switch (rng() % 9) {
        case 0:
        case 1: {
          const auto face = random_face(rng);
          list.push_back(face);
          model.push_back(face);
          break;
        }
        case 2: {  // index by index
          const auto face = random_face(rng);
          list.open_face();
          for (long long v : face) list.add_index(v);
          model.push_back(face);
          break;
        }
        case 3:  // a face of the list itself, appended to it
          if (n) {
            const std::size_t f = rng() % n;
            list.push_back(list[f]);
            model.push_back(model[f]);
          }
          break;
        case 4:
          if (n) {
            list.pop_back();
            model.pop_back();
          }
          break;
        case 5:
          if (n) {
            const std::size_t f = rng() % n;
            const auto face = random_face(rng);
            list.replace(f, face);
            model[f] = face;
          }
          break;
        case 6:
          if (n) {
            const std::size_t f = rng() % n;
            list.erase(f);
            model.erase(model.begin() + static_cast<std::ptrdiff_t>(f));
          }
          break;
        case 7:
          if (n) {  // a face written through a mutable view
            const std::size_t f = rng() % n;
            if (!model[f].empty()) {
              const std::size_t k = rng() % model[f].size();
              list[f][k] = model[f][k] = 7;
            }
          }
          break;
        default: {  // moved away: the moved-from list is an empty list that takes new faces
          FaceList moved = std::move(list);
          expect_same(moved, model, step);
          list = FaceList();
          list = std::move(moved);
          expect_same(moved, {}, step);
          moved.push_back({1, 2, 3});
          expect_same(moved, {{1, 2, 3}}, step);
          break;
        }
      }
      expect_same(list, model, step);
    }
  }
}

TEST(FaceList, ComparesByItsFaces) {
  const FaceList a{{0, 1, 2}, {2, 1, 3}}, b{{0, 1, 2}, {2, 1, 3}}, c{{0, 1, 2, 2, 1, 3}}, d{{0, 1}, {2, 2, 1, 3}};
  EXPECT_TRUE(a == b);
  EXPECT_FALSE(a != b);
  EXPECT_TRUE(a != c);  // the same indices, cut into other faces
  EXPECT_TRUE(a != d);
  FaceList e = a;
  e.clear();
  EXPECT_TRUE(e == FaceList());
  EXPECT_TRUE(e.empty());
}

}  // namespace
