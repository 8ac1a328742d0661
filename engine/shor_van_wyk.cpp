// Dynamic program over sub-polygons P_{i,j} = (v_i, ..., v_j), 0 <= i < j < m, closed by the edge j -> i
// (paper 3.1, Fig. 4, 5). Every triangulation of P has one triangle on the edge (m-1, 0), so the root is
// P_{0,m-1} and only sub-polygons that do not wrap around are needed: an upper-triangular table.
//
// Entry (i, j) holds the set of feasible pairs (r_i, r_j): the full turns of the triangulation angle of
// P_{i,j} at its two ends, beyond the counterclockwise sweep from v_{i+1} to v_j at i and from v_i to
// v_{j-1} at j. Gluing P_{i,k} and P_{k,j} along the positive triangle (i, k, j) adds the angles at i, k, j
// with the exact turn update of App. B; at k the sum must equal the prescribed angle, at the ends it must
// stay strictly below it (the rest of P still puts at least one triangle there).
//
// Speed: candidate splitting vertices k are found by AND-ing two bit rows (entries (i, .) feasible and
// entries (., j) feasible), so only k with both halves feasible cost orientation tests.
#include "engine/detail/shor_van_wyk.h"

#include <algorithm>
#include <cstdint>

#include "engine/detail/ear_reduction.h"
#include "engine/detail/exact_predicates.h"

namespace lipmap::detail {
namespace {

// m x m bits, row-major; row r is a bit set over columns.
class BitMatrix {
public:
  explicit BitMatrix(int m) : words_((m + 63) / 64), bits_(static_cast<std::size_t>(m) * words_, 0) {}
  void set(int r, int c) { bits_[index(r) + c / 64] |= std::uint64_t{1} << (c % 64); }
  bool get(int r, int c) const { return (bits_[index(r) + c / 64] >> (c % 64)) & 1; }
  const std::uint64_t* row(int r) const { return bits_.data() + index(r); }
  std::size_t bytes() const { return bits_.size() * sizeof(std::uint64_t); }

private:
  std::size_t index(int r) const { return static_cast<std::size_t>(r) * words_; }
  int words_;
  std::vector<std::uint64_t> bits_;
};

using Mask = std::uint64_t;  // bit r_i * width + r_j; width = max turns + 1 <= 8

class Table {
public:
  Table(const std::vector<Pt>& p, const std::vector<int>* turns, const AllowedTriangle* allowed,
        const CancelToken* cancel)
      : p_(p), m_(static_cast<int>(p.size())), turns_(turns), allowed_(allowed), cancel_(cancel), from_(m_), to_(m_) {
    if (turns_) width_ = *std::max_element(turns_->begin(), turns_->end()) + 1;
    // With all turns zero every feasible entry holds the single pair (0, 0): the bit rows say it all.
    if (width_ > 1) masks_.assign(static_cast<std::size_t>(m_) * (m_ - 1) / 2, 0);
    for (int i = 0; i + 1 < m_; ++i) mark_feasible(i, i + 1);  // 2-gons: nothing to triangulate
  }

  std::size_t bytes() const { return from_.bytes() + to_.bytes() + masks_.size() * sizeof(Mask); }

  // Fills the table; true when the whole polygon has a triangulation meeting the targets.
  bool fill() {
    split_hint_.assign(m_, -1);
    for (int d = 2; d < m_; ++d) {
      check_cancel(cancel_);
      for (int i = 0; i + d < m_; ++i) {
        const int j = i + d;
        tick();
        if (d == m_ - 1) return solve_root();
        const Mask mask = turns_ ? constrained_entry(i, j) : free_entry(i, j);
        if (mask) set_entry(i, j, mask);
      }
    }
    return false;  // m < 3 never reaches here: callers pass polygons with at least 3 vertices
  }

  // Top-down reconstruction (paper 3.1): triangle (i, k, j), then P_{i,k} and P_{k,j}.
  std::vector<Triangle> triangles() const {
    std::vector<Triangle> out;
    out.reserve(m_ - 2);
    struct Need { int i, j, ri, rj; };
    std::vector<Need> stack{{0, m_ - 1, turn(0), turn(m_ - 1)}};
    while (!stack.empty()) {
      const Need n = stack.back();
      stack.pop_back();
      if (n.j - n.i < 2) continue;
      Split s{};
      const bool found = for_each_split(n.i, n.j, [&](int k) { return find_split(n.i, k, n.j, n.ri, n.rj, s); });
      if (!found) throw InternalError("classify: triangulation table is inconsistent");
      out.push_back({n.i, s.k, n.j});
      stack.push_back({n.i, s.k, s.ri_left, s.rk_left});
      stack.push_back({s.k, n.j, s.rk_right, s.rj_right});
    }
    return out;
  }

private:
  struct Split { int k, ri_left, rk_left, rk_right, rj_right; };
  struct Glue { int at_i, at_k, at_j; };

  // Cancellation at a fine grain: one diagonal of a 20,000-vertex table is ~10^8 candidate splits, so the
  // token is looked at every 4096 entries or candidates (a clock read each time: well under 1% of the work).
  void tick() const {
    if (cancel_ && (++work_ & 4095) == 0) cancel_->check();
  }

  int turn(int v) const { return turns_ ? (*turns_)[v] : 0; }
  int prev(int v) const { return v == 0 ? m_ - 1 : v - 1; }
  int next(int v) const { return v + 1 == m_ ? 0 : v + 1; }
  Mask bit(int ri, int rj) const { return Mask{1} << (ri * width_ + rj); }

  std::size_t slot(int i, int j) const {  // packed upper triangle, j > i
    return static_cast<std::size_t>(i) * m_ - static_cast<std::size_t>(i) * (i + 1) / 2 + (j - i - 1);
  }
  Mask entry(int i, int j) const {
    if (j == i + 1) return bit(0, 0);
    if (masks_.empty()) return from_.get(i, j) ? bit(0, 0) : 0;
    return masks_[slot(i, j)];
  }
  void mark_feasible(int i, int j) { from_.set(i, j); to_.set(j, i); }
  void set_entry(int i, int j, Mask mask) {
    mark_feasible(i, j);
    if (!masks_.empty()) masks_[slot(i, j)] = mask;
  }

  // Calls f(k) for every k in (i, j) with P_{i,k} and P_{k,j} both feasible, until f returns true.
  template <class F>
  bool for_each_split(int i, int j, F&& f) const {
    const std::uint64_t* a = from_.row(i);
    const std::uint64_t* b = to_.row(j);
    const int lo = i + 1, hi = j - 1;
    for (int w = lo / 64; w <= hi / 64; ++w) {
      std::uint64_t bits = a[w] & b[w];
      if (w == lo / 64) bits &= ~std::uint64_t{0} << (lo % 64);
      if (w == hi / 64 && hi % 64 != 63) bits &= (std::uint64_t{1} << (hi % 64 + 1)) - 1;
      while (bits) {
        const int k = w * 64 + __builtin_ctzll(bits);
        bits &= bits - 1;
        tick();
        if (f(k)) return true;
      }
    }
    return false;
  }

  bool usable(int i, int k, int j) const {
    return orient(p_[i], p_[k], p_[j]) > 0 && (!allowed_ || (*allowed_)(i, k, j));
  }

  // Extra full turns created at i, k and j by gluing P_{i,k}, triangle (i,k,j) and P_{k,j} (App. B).
  Glue glue(int i, int k, int j) const {
    Glue g;
    g.at_i = extra_turn(p_[i], p_[i + 1], p_[k], p_[j]);
    g.at_k = extra_turn(p_[k], p_[k + 1], p_[j], p_[i]) + extra_turn(p_[k], p_[k + 1], p_[i], p_[k - 1]);
    g.at_j = extra_turn(p_[j], p_[i], p_[k], p_[j - 1]);
    return g;
  }

  // Largest turn count the end angle at i of P_{i,j} may have while staying strictly below the target angle
  // at i; negative when none can. The part of the target beyond the partial angle is the sweep from v_j to
  // v_{i-1}; it must be a positive angle.
  int cap_at_start(int i, int j) const {
    const Pt &c = p_[i], &last = p_[prev(i)];
    return turn(i) - extra_turn(c, p_[i + 1], p_[j], last) - (sector(c, p_[j], last) == 0 ? 1 : 0);
  }
  // Same at j: the target angle there is the sweep v_{j+1} -> v_i (rest of P) plus v_i -> v_{j-1} (P_{i,j}).
  int cap_at_end(int i, int j) const {
    const Pt &c = p_[j], &first = p_[next(j)];
    return turn(j) - extra_turn(c, first, p_[i], p_[j - 1]) - (sector(c, first, p_[i]) == 0 ? 1 : 0);
  }

  // Visits every way of gluing feasible pairs of P_{i,k} and P_{k,j} at k; f(ri, rj, a, b, c, d) receives
  // the turns of P_{i,j} at its ends and the pairs (a, b) of P_{i,k} and (c, d) of P_{k,j} used.
  template <class F>
  bool for_each_glued_pair(int i, int k, int j, const Glue& g, F&& f) const {
    const Mask left = entry(i, k), right = entry(k, j);
    for (int a = 0; a < width_; ++a) {
      for (int b = 0; b < width_; ++b) {
        if (!(left & bit(a, b))) continue;
        const int c = turn(k) - b - g.at_k;  // the turns P_{k,j} must bring at k
        if (c < 0 || c >= width_) continue;
        for (int d = 0; d < width_; ++d) {
          if ((right & bit(c, d)) && f(a + g.at_i, d + g.at_j, a, b, c, d)) return true;
        }
      }
    }
    return false;
  }

  // Neighbouring sub-polygons are usually split by the same vertex: before scanning all candidates, try
  // the splits found for P_{i,j-1} and P_{i+1,j} (split_hint_[i] and split_hint_[i+1] still hold them
  // from the previous diagonal when P_{i,j} is visited). Only a shortcut: the scan decides otherwise.
  template <class F>
  bool try_hints(int i, int j, F&& f) const {
    for (int k : {split_hint_[i], split_hint_[i + 1]}) {
      if (k <= i || k >= j) continue;
      if ((k == i + 1 || from_.get(i, k)) && (k == j - 1 || to_.get(j, k)) && f(k)) return true;
    }
    return false;
  }

  Mask constrained_entry(int i, int j) {
    const int cap_i = cap_at_start(i, j);
    if (cap_i < 0) return 0;
    const int cap_j = cap_at_end(i, j);
    if (cap_j < 0) return 0;
    // Every pair the caps allow: once the entry holds them all, no further split can add anything (with all
    // turns zero that is the single pair (0, 0), so the first valid split settles the entry).
    Mask full = 0;
    for (int ri = 0; ri <= std::min(cap_i, width_ - 1); ++ri)
      for (int rj = 0; rj <= std::min(cap_j, width_ - 1); ++rj) full |= bit(ri, rj);
    Mask mask = 0;
    auto add_split = [&](int k) {
      if (!usable(i, k, j)) return false;
      const Glue g = glue(i, k, j);
      for_each_glued_pair(i, k, j, g, [&](int ri, int rj, int, int, int, int) {
        if (ri <= cap_i && rj <= cap_j) mask |= bit(ri, rj);
        return false;
      });
      if (mask != full) return false;
      split_hint_[i] = k;
      return true;
    };
    if (try_hints(i, j, add_split)) return mask;
    for_each_split(i, j, add_split);
    return mask;
  }

  Mask free_entry(int i, int j) {
    auto positive = [&](int k) {
      if (!usable(i, k, j)) return false;
      split_hint_[i] = k;
      return true;
    };
    return (try_hints(i, j, positive) || for_each_split(i, j, positive)) ? bit(0, 0) : 0;
  }

  bool solve_root() {
    const int i = 0, j = m_ - 1;
    Split s{};
    const bool found = for_each_split(i, j, [&](int k) { return find_split(i, k, j, turn(i), turn(j), s); });
    if (found) set_entry(i, j, turns_ ? bit(turn(i), turn(j)) : bit(0, 0));
    return found;
  }

  // Does k split P_{i,j} so that its ends get exactly ri and rj turns? Fills s when it does.
  bool find_split(int i, int k, int j, int ri, int rj, Split& s) const {
    if (!usable(i, k, j)) return false;
    if (!turns_) {
      s = {k, 0, 0, 0, 0};
      return true;
    }
    return for_each_glued_pair(i, k, j, glue(i, k, j), [&](int gi, int gj, int a, int b, int c, int d) {
      if (gi != ri || gj != rj) return false;
      s = {k, a, b, c, d};
      return true;
    });
  }

  const std::vector<Pt>& p_;
  int m_;
  const std::vector<int>* turns_;
  const AllowedTriangle* allowed_;
  const CancelToken* cancel_;
  mutable std::uint32_t work_ = 0;
  int width_ = 1;
  BitMatrix from_;  // row i: j such that P_{i,j} is feasible
  BitMatrix to_;    // row j: i such that P_{i,j} is feasible
  std::vector<Mask> masks_;
  std::vector<int> split_hint_;  // per i: the split last found for an entry (i, .) of the current diagonal
};

}  // namespace

ShorVanWykResult shor_van_wyk(const std::vector<Pt>& polygon, const std::vector<int>* turns,
                              const CancelToken* cancel, const AllowedTriangle* allowed) {
  ShorVanWykResult result;
  if (polygon.size() < 3) return result;
  Table table(polygon, turns, allowed, cancel);
  result.table_bytes = table.bytes();
  if (table.fill()) result.triangles = table.triangles();
  return result;
}

std::optional<std::vector<Triangle>> triangulate_self_overlapping(const std::vector<Pt>& polygon,
                                                                  const AllowedTriangle* allowed) {
  if (polygon.size() < 3) return std::nullopt;
  if (polygon.size() == 3) {
    if (orient(polygon[0], polygon[1], polygon[2]) <= 0 || (allowed && !(*allowed)(0, 1, 2))) return std::nullopt;
    return std::vector<Triangle>{{0, 1, 2}};
  }
  if (turning_number(polygon) != 1) return std::nullopt;  // sum R_i = t - 1 must be 0
  return triangulate_with_rotation(polygon, std::vector<int>(polygon.size(), 0), allowed);
}

std::optional<std::vector<Triangle>> triangulate_with_rotation(const std::vector<Pt>& polygon,
                                                               const std::vector<int>& rotation,
                                                               const AllowedTriangle* allowed) {
  if (polygon.size() < 3) return std::nullopt;
  std::vector<int> turns = spike_turns(polygon);
  for (std::size_t k = 0; k < turns.size(); ++k) turns[k] += rotation[k];
  // Fast path: clip safe ears first (App. C), then the table on what is left. Every ear found is a valid
  // triangle of the answer, so a success is final. Without forbidden triangles a failure is final too (each
  // safe clip keeps "P meets the angles" unchanged). With them, an ear clipped early could in principle be the
  // wrong choice, so a failure is re-decided by the table on the whole polygon, unless the clipped polygon
  // fails even with every triangle allowed: then so does P (the clips are safe whatever was forbidden), and
  // with fewer triangles allowed it fails all the more. (Refused simplification steps of refine are mostly of
  // that kind: on the maze onto exp_strip, 631k of 656k such failures.)
  if (polygon.size() > 6) {
    EarReduction reduced = clip_ears(polygon, turns, nullptr, allowed);
    if (!reduced.ears.empty()) {
      std::vector<Pt> rest;
      for (int v : reduced.remaining) rest.push_back(polygon[v]);
      const AllowedTriangle mapped = [&](int i, int k, int j) {
        return !allowed || (*allowed)(reduced.remaining[i], reduced.remaining[k], reduced.remaining[j]);
      };
      if (auto tri = shor_van_wyk(rest, &reduced.turns, nullptr, &mapped).triangles) {
        std::vector<Triangle> all = std::move(reduced.ears);
        for (const Triangle& t : *tri)
          all.push_back({reduced.remaining[t[0]], reduced.remaining[t[1]], reduced.remaining[t[2]]});
        return all;
      }
      if (!allowed || !shor_van_wyk(rest, &reduced.turns, nullptr, nullptr).triangles) return std::nullopt;
    }
  }
  return shor_van_wyk(polygon, &turns, nullptr, allowed).triangles;
}

}  // namespace lipmap::detail
