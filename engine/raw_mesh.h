// The engine's input as it arrives (JSON arrays, a mesh file, a glTF primitive), before any check. Std-only,
// so that the codecs include it; engine/disk_mesh.h holds what validate makes of it.
#pragma once

#include <algorithm>
#include <cstddef>
#include <initializer_list>
#include <iterator>
#include <optional>
#include <vector>

#include "engine/geometry.h"

namespace lipmap {

// One face of a FaceList: a view of its vertex indices (Index is long long, or const long long).
template <class Index>
class FaceIndices {
public:
  FaceIndices(Index* first, std::size_t size) : first_(first), size_(size) {}
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  Index& operator[](std::size_t k) const { return first_[k]; }
  Index* begin() const { return first_; }
  Index* end() const { return first_ + size_; }
  operator std::vector<long long>() const { return {first_, first_ + size_}; }
  operator FaceIndices<const long long>() const { return {first_, size_}; }

private:
  Index* first_;
  std::size_t size_;
};

// A face compares equal to the same indices in a vector.
template <class Index>
bool operator==(const FaceIndices<Index>& a, const std::vector<long long>& b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin());
}

// The faces of a mesh as they arrive, each any number of vertex indices (validate judges them), stored flat:
// one array of indices and one of where each face starts. A million-triangle request is read into two
// arrays, not a million small ones (whose allocations cost more than reading the numbers).
class FaceList {
public:
  using Face = FaceIndices<long long>;
  using ConstFace = FaceIndices<const long long>;

  FaceList() = default;
  FaceList(std::initializer_list<std::initializer_list<long long>> faces) {
    for (const auto& f : faces) push_back(f);
  }

  std::size_t size() const { return starts_.size() - 1; }
  bool empty() const { return size() == 0; }
  Face operator[](std::size_t f) { return {indices_.data() + starts_[f], starts_[f + 1] - starts_[f]}; }
  ConstFace operator[](std::size_t f) const { return {indices_.data() + starts_[f], starts_[f + 1] - starts_[f]}; }
  ConstFace back() const { return (*this)[size() - 1]; }

  void push_back(std::initializer_list<long long> face) { push_back<std::initializer_list<long long>>(face); }
  template <class Range>
  void push_back(const Range& face) {
    indices_.insert(indices_.end(), std::begin(face), std::end(face));
    starts_.push_back(indices_.size());
  }
  // A face index by index: open_face(), then add_index for each of its indices.
  void open_face() { starts_.push_back(indices_.size()); }
  void add_index(long long v) {
    indices_.push_back(v);
    ++starts_.back();
  }
  void pop_back() {
    starts_.pop_back();
    indices_.resize(starts_.back());
  }
  // Face f replaced by `face` (of any size), or removed; both move every later face when the size changes.
  void replace(std::size_t f, std::initializer_list<long long> face) { replace<std::initializer_list<long long>>(f, face); }
  template <class Range>
  void replace(std::size_t f, const Range& face) {
    const std::vector<long long> copy(std::begin(face), std::end(face));  // face may be a view into this list
    const std::ptrdiff_t grow = static_cast<std::ptrdiff_t>(copy.size()) - static_cast<std::ptrdiff_t>(starts_[f + 1] - starts_[f]);
    indices_.erase(indices_.begin() + static_cast<std::ptrdiff_t>(starts_[f]), indices_.begin() + static_cast<std::ptrdiff_t>(starts_[f + 1]));
    indices_.insert(indices_.begin() + static_cast<std::ptrdiff_t>(starts_[f]), copy.begin(), copy.end());
    for (std::size_t g = f + 1; g < starts_.size(); ++g) starts_[g] = static_cast<std::size_t>(static_cast<std::ptrdiff_t>(starts_[g]) + grow);
  }
  void erase(std::size_t f) {
    replace(f, std::initializer_list<long long>{});
    starts_.erase(starts_.begin() + static_cast<std::ptrdiff_t>(f) + 1);
  }
  // Room for `faces` faces with `indices` indices in all (triangles unless told).
  void reserve(std::size_t faces, std::size_t indices = 0) {
    starts_.reserve(faces + 1);
    indices_.reserve(indices ? indices : 3 * faces);
  }
  void clear() {
    indices_.clear();
    starts_.assign(1, 0);
  }

  // Every index, face after face.
  const std::vector<long long>& indices() const { return indices_; }

  class const_iterator {
  public:
    using iterator_category = std::forward_iterator_tag;
    using value_type = ConstFace;
    using difference_type = std::ptrdiff_t;
    using pointer = void;
    using reference = ConstFace;
    const_iterator(const FaceList* list, std::size_t f) : list_(list), f_(f) {}
    ConstFace operator*() const { return (*list_)[f_]; }
    const_iterator& operator++() {
      ++f_;
      return *this;
    }
    bool operator==(const const_iterator& o) const { return f_ == o.f_; }
    bool operator!=(const const_iterator& o) const { return f_ != o.f_; }

  private:
    const FaceList* list_;
    std::size_t f_;
  };
  const_iterator begin() const { return {this, 0}; }
  const_iterator end() const { return {this, size()}; }

  bool operator==(const FaceList& o) const { return starts_ == o.starts_ && indices_ == o.indices_; }
  bool operator!=(const FaceList& o) const { return !(*this == o); }
  bool operator==(const std::vector<std::vector<long long>>& o) const {
    if (o.size() != size()) return false;
    for (std::size_t f = 0; f < size(); ++f)
      if (!((*this)[f] == o[f])) return false;
    return true;
  }

private:
  std::vector<long long> indices_;
  std::vector<std::size_t> starts_{0};  // face f is indices_[starts_[f], starts_[f + 1])
};

// Indices are wide so that out-of-range and negative values survive until validate can name them.
struct RawMesh {
  std::vector<Point3> vertices;
  FaceList faces;
};

// Boundary positions as they arrive: positions[k] is the image of the k-th boundary vertex, in the order
// of `vertices` when given, else of DiskMesh::boundary_loop.
struct RawBoundary {
  std::optional<std::vector<long long>> vertices;
  std::vector<Point2> positions;
  std::optional<std::vector<long long>> rotation_indices;
};

}  // namespace lipmap
