// The engine's input as it arrives (JSON arrays, a mesh file, a glTF primitive), before any check. Std-only,
// so that the codecs include it; engine/disk_mesh.h holds what validate makes of it.
#pragma once

#include <algorithm>
#include <cassert>
#include <cstddef>
#include <initializer_list>
#include <iterator>
#include <optional>
#include <type_traits>
#include <vector>

#include "engine/geometry.h"

namespace lipmap {

// One face of a FaceList: a view of its vertex indices (Index is long long, or const long long).
template <class Index>
class FaceIndices {
public:
  FaceIndices(Index* first, std::size_t size) : first_(first), size_(size) {}
  // A mutable face is also a read-only one.
  template <class Other, class = std::enable_if_t<std::is_const_v<Index> && !std::is_const_v<Other>>>
  FaceIndices(const FaceIndices<Other>& o) : first_(o.begin()), size_(o.size()) {}
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  Index& operator[](std::size_t k) const { return first_[k]; }
  Index* begin() const { return first_; }
  Index* end() const { return first_ + size_; }
  operator std::vector<long long>() const { return {first_, first_ + size_}; }

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
// one array of indices and one of where each face ends. A million-triangle request is read into two arrays,
// not a million small ones (whose allocations cost more than reading the numbers). Empty arrays are an empty
// list, so a moved-from list is one too.
class FaceList {
public:
  using Face = FaceIndices<long long>;
  using ConstFace = FaceIndices<const long long>;

  FaceList() = default;
  FaceList(std::initializer_list<std::initializer_list<long long>> faces) {
    for (const auto& f : faces) push_back(f);
  }

  std::size_t size() const { return ends_.size(); }
  bool empty() const { return ends_.empty(); }
  Face operator[](std::size_t f) { return {indices_.data() + start(f), ends_[f] - start(f)}; }
  ConstFace operator[](std::size_t f) const { return {indices_.data() + start(f), ends_[f] - start(f)}; }
  ConstFace back() const { return (*this)[size() - 1]; }

  void push_back(std::initializer_list<long long> face) { append(face.begin(), face.end()); }
  // A face of this list or another, copied first: inserting a vector's own elements into it is undefined.
  void push_back(ConstFace face) { push_back(std::vector<long long>(face)); }
  void push_back(Face face) { push_back(std::vector<long long>(face)); }
  template <class Range>
  void push_back(const Range& face) {
    append(std::begin(face), std::end(face));
  }
  // A face index by index: open_face(), then add_index for each of its indices.
  void open_face() { ends_.push_back(indices_.size()); }
  void add_index(long long v) {
    assert(!ends_.empty() && "open_face first");
    indices_.push_back(v);
    ++ends_.back();
  }
  void pop_back() {
    ends_.pop_back();
    indices_.resize(ends_.empty() ? 0 : ends_.back());
  }
  // Face f replaced by `face` (of any size), or removed: every later face moves when the size changes.
  void replace(std::size_t f, std::initializer_list<long long> face) { replace(f, std::vector<long long>(face)); }
  void replace(std::size_t f, const std::vector<long long>& face) {
    std::vector<long long> indices(indices_.begin(), indices_.begin() + static_cast<std::ptrdiff_t>(start(f)));
    indices.insert(indices.end(), face.begin(), face.end());
    indices.insert(indices.end(), indices_.begin() + static_cast<std::ptrdiff_t>(ends_[f]), indices_.end());
    const std::ptrdiff_t grow = static_cast<std::ptrdiff_t>(face.size()) - static_cast<std::ptrdiff_t>(ends_[f] - start(f));
    indices_.swap(indices);
    for (std::size_t g = f; g < ends_.size(); ++g) ends_[g] = static_cast<std::size_t>(static_cast<std::ptrdiff_t>(ends_[g]) + grow);
  }
  void erase(std::size_t f) {
    replace(f, std::vector<long long>{});
    ends_.erase(ends_.begin() + static_cast<std::ptrdiff_t>(f));
  }
  // Room for `faces` faces with `indices` indices in all (triangles unless told).
  void reserve(std::size_t faces, std::size_t indices = 0) {
    ends_.reserve(faces);
    indices_.reserve(indices ? indices : 3 * faces);
  }
  void clear() {
    indices_.clear();
    ends_.clear();
  }

  // Every index, face after face.
  const std::vector<long long>& indices() const { return indices_; }

  class const_iterator {
  public:
    using iterator_category = std::input_iterator_tag;
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
    const_iterator operator++(int) {
      const_iterator was = *this;
      ++f_;
      return was;
    }
    bool operator==(const const_iterator& o) const { return f_ == o.f_; }
    bool operator!=(const const_iterator& o) const { return f_ != o.f_; }

  private:
    const FaceList* list_;
    std::size_t f_;
  };
  const_iterator begin() const { return {this, 0}; }
  const_iterator end() const { return {this, size()}; }

  bool operator==(const FaceList& o) const { return ends_ == o.ends_ && indices_ == o.indices_; }
  bool operator!=(const FaceList& o) const { return !(*this == o); }
  bool operator==(const std::vector<std::vector<long long>>& o) const {
    if (o.size() != size()) return false;
    for (std::size_t f = 0; f < size(); ++f)
      if (!((*this)[f] == o[f])) return false;
    return true;
  }

private:
  std::size_t start(std::size_t f) const { return f == 0 ? 0 : ends_[f - 1]; }
  template <class It>
  void append(It first, It last) {
    indices_.insert(indices_.end(), first, last);
    ends_.push_back(indices_.size());
  }

  std::vector<long long> indices_;
  std::vector<std::size_t> ends_;  // face f is indices_[f ? ends_[f - 1] : 0, ends_[f])
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
