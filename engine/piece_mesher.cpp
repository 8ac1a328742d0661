// CGAL part of the target-mesh stage: exact simplicity test and constrained Delaunay meshing of one simple
// piece without ever splitting a constrained edge (see engine/detail/piece_mesher.h).
#include "engine/detail/piece_mesher.h"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Delaunay_mesh_face_base_2.h>
#include <CGAL/Delaunay_mesh_size_criteria_2.h>
#include <CGAL/Delaunay_mesh_vertex_base_2.h>
#include <CGAL/Delaunay_mesher_no_edge_refinement_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_2_algorithms.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "engine/detail/exact_predicates.h"
#include "engine/error.h"

namespace lipmap::detail {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using KPoint = K::Point_2;

struct VertexId {
  int id = -1;  // -1: a Steiner point the mesher inserted
};

using Vb = CGAL::Triangulation_vertex_base_with_info_2<VertexId, K, CGAL::Delaunay_mesh_vertex_base_2<K>>;
using Fb = CGAL::Delaunay_mesh_face_base_2<K>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<K, Tds, CGAL::Exact_predicates_tag>;

KPoint to_k(const Point2& p) { return KPoint(p.x, p.y); }

// CGAL's size-and-shape criteria with the size bound taken from a sizing field at the face's centroid.
class Graded_criteria : public CGAL::Delaunay_mesh_size_criteria_2<Cdt> {
  using Base = CGAL::Delaunay_mesh_size_criteria_2<Cdt>;

public:
  Graded_criteria(double aspect_bound, const SizingField& field, double size_factor)
      : Base(aspect_bound, 1.0), field_(&field), size_factor_(size_factor) {}

  class Is_bad {
  public:
    Is_bad(double aspect_bound, const SizingField* field, double size_factor)
        : B_(aspect_bound), field_(field), size_factor_(size_factor) {}

    CGAL::Mesh_2::Face_badness operator()(const Quality q) const {
      if (q.size() > 1) return CGAL::Mesh_2::IMPERATIVELY_BAD;
      return q.sine() < B_ ? CGAL::Mesh_2::BAD : CGAL::Mesh_2::NOT_BAD;
    }

    CGAL::Mesh_2::Face_badness operator()(const Cdt::Face_handle& fh, Quality& q) const {
      const KPoint& pa = fh->vertex(0)->point();
      const KPoint& pb = fh->vertex(1)->point();
      const KPoint& pc = fh->vertex(2)->point();
      const double a = CGAL::to_double(CGAL::squared_distance(pb, pc));
      const double b = CGAL::to_double(CGAL::squared_distance(pc, pa));
      const double c = CGAL::to_double(CGAL::squared_distance(pa, pb));
      double m1 = a, m2 = b, m3 = c;  // sorted descending into m1 >= m2 >= m3
      if (m1 < m2) std::swap(m1, m2);
      if (m2 < m3) std::swap(m2, m3);
      if (m1 < m2) std::swap(m1, m2);
      const Point2 centroid{(pa.x() + pb.x() + pc.x()) / 3, (pa.y() + pb.y() + pc.y()) / 3};
      const double bound = size_factor_ * (*field_)(centroid);
      q.second = m1 / (bound * bound);
      if (q.size() > 1) {
        q.first = 1;
        return CGAL::Mesh_2::IMPERATIVELY_BAD;
      }
      const double area2 = 2 * CGAL::to_double(CGAL::area(pa, pb, pc));
      q.first = (area2 * area2) / (m1 * m2);
      return q.sine() < B_ ? CGAL::Mesh_2::BAD : CGAL::Mesh_2::NOT_BAD;
    }

  private:
    double B_;
    const SizingField* field_;
    double size_factor_;
  };

  Is_bad is_bad_object() const { return Is_bad(this->bound(), field_, size_factor_); }

private:
  const SizingField* field_;
  double size_factor_;
};

// Where the mesher may put a point p next to a constrained edge ab (an edge it may not split). CGAL's
// Delaunay_mesher_no_edge_refinement_2 refuses any p inside ab's diametral circle (Gabriel); near a polygon
// edge much longer than the target size that leaves large fans of needle triangles that are never refined.
// Here p is refused only when the triangle (a, b, p) its insertion creates would be bad: an angle below the
// lens angle at a or b, or above kMaxApexDeg at p. A well-shaped triangle on ab needs a mesh about as
// coarse as ab around it; when the sizing field is capped below |ab| (to keep the triangle count), the lens
// shrinks to the height the field allows (tan(lens angle) = cap / |ab|, at least kMinLensDeg) and the apex
// limit is dropped, so that ab gets one flat triangle instead of a fan.
constexpr double kMaxApexDeg = 120.0;
// Lattice points keep this distance (in lattice spacings) from the piece boundary.
constexpr double kLatticeClearance = 0.7;
constexpr double kMinLensDeg = 3.0;
thread_local double t_lens_tan = std::tan(20.0 * M_PI / 180.0);
thread_local double t_lens_cap = INFINITY;

// Whether a point p may be joined to the constrained edge ab (see above).
bool lens_ok(double ax, double ay, double bx, double by, double px, double py) {
  const double ex = bx - ax, ey = by - ay, len = std::hypot(ex, ey);
  if (!(len > 0)) return true;
  double tan_lens = t_lens_tan;
  bool apex_limit = true;
  if (t_lens_cap < len * t_lens_tan) {
    tan_lens = std::max(t_lens_cap / len, std::tan(kMinLensDeg * M_PI / 180.0));
    apex_limit = false;
  }
  // Angles at a and b through tangents: height over the line ab against the distances along it.
  const double ux = px - ax, uy = py - ay;
  const double along = (ux * ex + uy * ey) / len;  // from a towards b
  const double height = std::fabs(ux * ey - uy * ex) / len;
  if (along > 0 && along < len && (height < tan_lens * along || height < tan_lens * (len - along))) return false;
  if (apex_limit) {
    static const double cos_apex = std::cos(kMaxApexDeg * M_PI / 180.0);
    const double wx = px - bx, wy = py - by;
    const double d = std::sqrt((ux * ux + uy * uy) * (wx * wx + wy * wy));
    if (d > 0 && (ux * wx + uy * wy) / d < cos_apex) return false;
  }
  return true;
}

// How far from ab the region refused by lens_ok reaches (an upper bound).
double lens_reach(double len) {
  if (t_lens_cap < len * t_lens_tan)
    return 0.5 * len * std::max(t_lens_cap / len, std::tan(kMinLensDeg * M_PI / 180.0));
  return 0.5 * len * std::max(t_lens_tan, std::tan((90.0 - kMaxApexDeg / 2) * M_PI / 180.0));
}

struct Lens_conform : CGAL::Mesh_2::Is_locally_conforming_Gabriel<Cdt> {
  using Base = CGAL::Mesh_2::Is_locally_conforming_Gabriel<Cdt>;
  using Base::operator();

  bool operator()(const Cdt& tr, const Cdt::Face_handle& fh, const int i, const KPoint& p) const {
    return (*this)(tr, fh->vertex(tr.cw(i)), fh->vertex(tr.ccw(i)), p);
  }
  bool operator()(const Cdt&, const Cdt::Vertex_handle& va, const Cdt::Vertex_handle& vb, const KPoint& p) const {
    return lens_ok(va->point().x(), va->point().y(), vb->point().x(), vb->point().y(), p.x(), p.y());
  }
};

// Hexagonal lattice of Steiner points over the part of a piece where the sizing field is at its base value
// and that is at least `clearance` away from the piece boundary, inserted in one spatially sorted batch
// before Delaunay refinement: the lattice's equilateral triangles are already good, so the mesher only has
// to work in the boundary layer and in the graded zones. Much faster than inserting the same points one
// circumcenter at a time. Requires the domain to be marked; leaves it to be marked again.
std::size_t seed_lattice(Cdt& cdt, const std::vector<Point2>& boundary, const SizingField& field, double spacing,
                         double clearance, std::size_t max_points) {
  const std::size_t m = boundary.size();
  double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  for (const Point2& p : boundary) x0 = std::min(x0, p.x), y0 = std::min(y0, p.y), x1 = std::max(x1, p.x), y1 = std::max(y1, p.y);
  const double row = spacing * std::sqrt(3.0) / 2;
  const double cols = std::floor((x1 - x0) / spacing) + 1, rows = std::floor((y1 - y0) / row) + 1;
  if (!(cols * rows <= 4.0 * static_cast<double>(max_points) + 1e6)) return 0;  // far too many for the piece
  // Boundary segments bucketed on a grid of cell `cell` for the clearance test.
  const double cell = std::max(clearance, spacing);
  const int gx = static_cast<int>((x1 - x0) / cell) + 1, gy = static_cast<int>((y1 - y0) / cell) + 1;
  if (static_cast<double>(gx) * gy > 4.0 * static_cast<double>(max_points) + 1e6) return 0;
  std::vector<std::vector<int>> buckets(static_cast<std::size_t>(gx) * gy);
  auto clampi = [](double v, int hi) { return std::clamp(static_cast<int>(std::floor(v)), 0, hi - 1); };
  for (std::size_t i = 0; i < m; ++i) {
    const Point2& a = boundary[i];
    const Point2& b = boundary[(i + 1) % m];
    const double r = std::max(clearance, lens_reach(std::hypot(b.x - a.x, b.y - a.y)));
    const int i0 = clampi((std::min(a.x, b.x) - r - x0) / cell, gx), i1 = clampi((std::max(a.x, b.x) + r - x0) / cell, gx);
    const int j0 = clampi((std::min(a.y, b.y) - r - y0) / cell, gy), j1 = clampi((std::max(a.y, b.y) + r - y0) / cell, gy);
    for (int j = j0; j <= j1; ++j)
      for (int k = i0; k <= i1; ++k) buckets[static_cast<std::size_t>(j) * gx + k].push_back(static_cast<int>(i));
  }
  const double c2 = clearance * clearance;
  auto clear_of_boundary = [&](const Point2& p) {
    const auto& bucket = buckets[static_cast<std::size_t>(clampi((p.y - y0) / cell, gy)) * gx + clampi((p.x - x0) / cell, gx)];
    for (int i : bucket) {
      const Point2& a = boundary[i];
      const Point2& b = boundary[(i + 1) % m];
      const double ex = b.x - a.x, ey = b.y - a.y, l2 = ex * ex + ey * ey;
      double t = l2 > 0 ? ((p.x - a.x) * ex + (p.y - a.y) * ey) / l2 : 0.0;
      t = std::clamp(t, 0.0, 1.0);
      const double dx = p.x - (a.x + t * ex), dy = p.y - (a.y + t * ey);
      if (dx * dx + dy * dy < c2 || !lens_ok(a.x, a.y, b.x, b.y, p.x, p.y)) return false;
    }
    return true;
  };
  const double base = field.base() * 1.0001;
  std::vector<KPoint> points;
  Cdt::Face_handle hint;
  for (int j = 0; j < static_cast<int>(rows); ++j) {
    const double y = y0 + (j + 0.5) * row;
    const double shift = (j % 2) ? 0.5 * spacing : 0.0;
    for (int i = 0; i < static_cast<int>(cols); ++i) {
      const Point2 p{x0 + shift + (i + 0.25) * spacing, y};
      if (!clear_of_boundary(p) || field(p) > base) continue;
      Cdt::Locate_type lt;
      int li;
      const KPoint kp(p.x, p.y);
      hint = cdt.locate(kp, lt, li, hint);
      if (lt != Cdt::FACE || !hint->is_in_domain()) continue;
      points.push_back(kp);
      if (points.size() >= max_points) break;
    }
    if (points.size() >= max_points) break;
  }
  cdt.insert(points.begin(), points.end());
  return points.size();
}

}  // namespace

SizingField::SizingField(double base, double grading, std::vector<SizeSource> sources)
    : base_(base), grading_(grading) {
  for (SizeSource& s : sources)
    if (s.size > base_) sources_.push_back(s);
  if (sources_.empty()) return;
  double xmin = INFINITY, ymin = INFINITY, xmax = -INFINITY, ymax = -INFINITY, reach_sum = 0;
  auto reach = [&](const SizeSource& s) { return (s.size - base_) / grading_; };
  for (const SizeSource& s : sources_) {
    const double r = reach(s);
    reach_sum += r;
    xmin = std::min({xmin, s.a.x - r, s.b.x - r});
    ymin = std::min({ymin, s.a.y - r, s.b.y - r});
    xmax = std::max({xmax, s.a.x + r, s.b.x + r});
    ymax = std::max({ymax, s.a.y + r, s.b.y + r});
  }
  // Cells about the size of a typical region of influence, at most ~16 per source overall.
  const double w = std::max(xmax - xmin, 1e-300), hgt = std::max(ymax - ymin, 1e-300);
  double cell = std::max(reach_sum / static_cast<double>(sources_.size()), 1e-300);
  const double max_cells = 16.0 * static_cast<double>(sources_.size()) + 16.0;
  if ((w / cell + 1) * (hgt / cell + 1) > max_cells) cell = std::sqrt(w * hgt / max_cells) + std::max(w, hgt) / max_cells;
  cell_ = cell;
  x0_ = xmin;
  y0_ = ymin;
  nx_ = std::max(1, static_cast<int>(std::ceil(w / cell_)));
  ny_ = std::max(1, static_cast<int>(std::ceil(hgt / cell_)));
  std::vector<std::vector<int>> cells(static_cast<std::size_t>(nx_) * ny_);
  auto clampi = [](double v, int hi) { return std::clamp(static_cast<int>(std::floor(v)), 0, hi - 1); };
  for (std::size_t i = 0; i < sources_.size(); ++i) {
    const SizeSource& s = sources_[i];
    const double r = reach(s);
    const int i0 = clampi((std::min(s.a.x, s.b.x) - r - x0_) / cell_, nx_);
    const int i1 = clampi((std::max(s.a.x, s.b.x) + r - x0_) / cell_, nx_);
    const int j0 = clampi((std::min(s.a.y, s.b.y) - r - y0_) / cell_, ny_);
    const int j1 = clampi((std::max(s.a.y, s.b.y) + r - y0_) / cell_, ny_);
    for (int j = j0; j <= j1; ++j)
      for (int k = i0; k <= i1; ++k) cells[static_cast<std::size_t>(j) * nx_ + k].push_back(static_cast<int>(i));
  }
  // Largest sizes first: a query stops at the first source that cannot raise its current value.
  for (auto& c : cells)
    std::sort(c.begin(), c.end(), [&](int x, int y) { return sources_[x].size > sources_[y].size; });
  cell_start_.assign(cells.size() + 1, 0);
  for (std::size_t c = 0; c < cells.size(); ++c) cell_start_[c + 1] = cell_start_[c] + static_cast<int>(cells[c].size());
  cell_items_.reserve(cell_start_.back());
  for (const auto& c : cells) cell_items_.insert(cell_items_.end(), c.begin(), c.end());
}

double SizingField::operator()(const Point2& p) const {
  double s = base_;
  if (sources_.empty()) return s;
  const double fx = (p.x - x0_) / cell_, fy = (p.y - y0_) / cell_;
  if (!(fx >= 0 && fy >= 0 && fx < nx_ && fy < ny_)) return s;
  const std::size_t c = static_cast<std::size_t>(static_cast<int>(fy)) * nx_ + static_cast<int>(fx);
  for (int k = cell_start_[c]; k < cell_start_[c + 1]; ++k) {
    const SizeSource& src = sources_[cell_items_[k]];
    if (src.size <= s) break;
    // Raises s only within distance (size - s) / grading of the segment.
    const double r = (src.size - s) / grading_;
    const double ex = src.b.x - src.a.x, ey = src.b.y - src.a.y;
    const double l2 = ex * ex + ey * ey;
    double t = l2 > 0 ? ((p.x - src.a.x) * ex + (p.y - src.a.y) * ey) / l2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    const double dx = p.x - (src.a.x + t * ex), dy = p.y - (src.a.y + t * ey);
    const double d2 = dx * dx + dy * dy;
    if (d2 < r * r) s = src.size - grading_ * std::sqrt(d2);
  }
  return s;
}

bool is_simple_polygon(const std::vector<Point2>& polygon) {
  if (polygon.size() < 3) return false;
  std::vector<KPoint> pts;
  pts.reserve(polygon.size());
  for (const Point2& p : polygon) pts.push_back(to_k(p));
  return CGAL::is_simple_2(pts.begin(), pts.end(), K());
}

namespace {

struct Box {
  double x0, y0, x1, y1;
};

Box box_of(const Point2& a, const Point2& b) {
  return {std::min(a.x, b.x), std::min(a.y, b.y), std::max(a.x, b.x), std::max(a.y, b.y)};
}

bool boxes_meet(const Box& a, const Box& b) { return a.x0 <= b.x1 && b.x0 <= a.x1 && a.y0 <= b.y1 && b.y0 <= a.y1; }

}  // namespace

bool glued_union_is_simple(const std::vector<Point2>& a_path, const std::vector<Point2>& b_path) {
  const std::size_t na = a_path.size(), nb = b_path.size();  // segments: na - 1 and nb - 1
  if (na < 2 || nb < 2) return false;
  // Whole-path boxes first: only segments reaching into the other path's box can meet it.
  Box ba{INFINITY, INFINITY, -INFINITY, -INFINITY}, bb = ba;
  for (const Point2& p : a_path) ba = {std::min(ba.x0, p.x), std::min(ba.y0, p.y), std::max(ba.x1, p.x), std::max(ba.y1, p.y)};
  for (const Point2& p : b_path) bb = {std::min(bb.x0, p.x), std::min(bb.y0, p.y), std::max(bb.x1, p.x), std::max(bb.y1, p.y)};
  std::vector<std::size_t> near_b;  // b segments inside A's box
  for (std::size_t j = 0; j + 1 < nb; ++j)
    if (boxes_meet(box_of(b_path[j], b_path[j + 1]), ba)) near_b.push_back(j);
  const Point2& b = a_path.front();
  const Point2& a = a_path.back();
  for (std::size_t i = 0; i + 1 < na; ++i) {
    const Box si = box_of(a_path[i], a_path[i + 1]);
    if (!boxes_meet(si, bb)) continue;
    const KPoint p0 = to_k(a_path[i]), p1 = to_k(a_path[i + 1]);
    for (std::size_t j : near_b) {
      if (!boxes_meet(si, box_of(b_path[j], b_path[j + 1]))) continue;
      const bool a_last = i + 2 == na, b_first = j == 0, b_last = j + 2 == nb, a_first = i == 0;
      if (a_last && b_first) {
        // Consecutive in the union at a: (x, a) then (a, y); they may only share a.
        const Point2& x = a_path[i];
        const Point2& y = b_path[1];
        if (orient(x, a, y) == 0 && same_ray(to_k(a), to_k(x), to_k(y))) return false;
        continue;
      }
      if (b_last && a_first) {
        // Consecutive at b: (z, b) then (b, w).
        const Point2& z = b_path[j];
        const Point2& w = a_path[1];
        if (orient(z, b, w) == 0 && same_ray(to_k(b), to_k(z), to_k(w))) return false;
        continue;
      }
      if (CGAL::do_intersect(K::Segment_2(p0, p1), K::Segment_2(to_k(b_path[j]), to_k(b_path[j + 1])))) return false;
    }
  }
  return true;
}

double signed_area(const std::vector<Point2>& polygon) {
  // Relative to the first vertex: far from the origin, x * y products would swamp a small area.
  double a = 0;
  const std::size_t m = polygon.size();
  if (m < 3) return 0;
  const Point2& o = polygon[0];
  for (std::size_t i = 1; i + 1 < m; ++i) {
    const double px = polygon[i].x - o.x, py = polygon[i].y - o.y;
    const double qx = polygon[i + 1].x - o.x, qy = polygon[i + 1].y - o.y;
    a += px * qy - py * qx;
  }
  return 0.5 * a;
}

PieceMeshResult mesh_simple_piece(const std::vector<Point2>& boundary, const SizingField& field,
                                  double size_factor, double min_angle_deg, double lens_cap,
                                  double lattice_spacing, std::size_t max_steiner, const CancelToken* cancel) {
  const std::size_t m = boundary.size();
  if (m < 3) throw InternalError("target mesh: piece with fewer than 3 vertices");

  Cdt cdt;
  std::vector<Cdt::Vertex_handle> handles(m);
  for (std::size_t i = 0; i < m; ++i) {
    handles[i] = cdt.insert(to_k(boundary[i]));
    if (handles[i]->info().id != -1)
      throw InternalError("target mesh: piece has two vertices at the same position (local " +
                          std::to_string(handles[i]->info().id) + " and " + std::to_string(i) + ")");
    handles[i]->info().id = static_cast<int>(i);
  }
  for (std::size_t i = 0; i < m; ++i) cdt.insert_constraint(handles[i], handles[(i + 1) % m]);
  if (cdt.number_of_vertices() != m)
    throw InternalError("target mesh: piece boundary intersects itself (" +
                        std::to_string(cdt.number_of_vertices() - m) + " intersection points)");

  // sin^2 of the smallest angle (CGAL's aspect bound B); 0 disables the shape criterion.
  const double s = std::sin(min_angle_deg * M_PI / 180.0);
  // CGAL's Delaunay_mesher_no_edge_refinement_2, assembled here with the lens rule instead of Gabriel's.
  using EdgesBase = CGAL::Mesh_2::Do_not_refine_edges<Cdt, Lens_conform>;
  using EdgesLevel = CGAL::Mesh_2::Refine_edges<Cdt, Lens_conform, EdgesBase>;
  using FacesLevel = CGAL::Mesh_2::Refine_faces<Cdt, Graded_criteria, EdgesLevel>;
  t_lens_tan = std::tan(std::clamp(min_angle_deg, 1.0, 25.0) * M_PI / 180.0);
  t_lens_cap = lens_cap;
  Graded_criteria criteria(s * s, field, size_factor);
  CGAL::Null_mesher_level null_level;
  CGAL::Null_mesh_visitor null_visitor;
  EdgesLevel edges_level(cdt, null_level);
  FacesLevel faces_level(cdt, criteria, edges_level);
  // The domain: faces not reachable from the infinite face without crossing the piece boundary.
  using Marker = CGAL::Delaunay_mesher_no_edge_refinement_2<Cdt, Graded_criteria>;
  Marker::mark_convex_hull(cdt);
  if (lattice_spacing > 0) {
    if (seed_lattice(cdt, boundary, field, lattice_spacing, kLatticeClearance * lattice_spacing, max_steiner) > 0)
      Marker::mark_convex_hull(cdt);
    check_cancel(cancel);
  }
  edges_level.scan_triangulation();
  faces_level.scan_triangulation();

  PieceMeshResult result;
  std::size_t steps = 0;
  while (!faces_level.is_algorithm_done()) {
    if (cdt.number_of_vertices() - m >= max_steiner) {
      result.hit_point_cap = true;
      break;
    }
    faces_level.one_step(null_visitor);
    if ((++steps & 1023u) == 0) check_cancel(cancel);
  }

  // Ids for the Steiner points, in the triangulation's vertex order.
  int next = static_cast<int>(m);
  for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v) {
    if (v->info().id == -1) {
      v->info().id = next++;
      result.steiner.push_back(Point2{v->point().x(), v->point().y()});
    }
  }

  // Every boundary edge must still be one edge of the triangulation: no Steiner point on it.
  for (std::size_t i = 0; i < m; ++i) {
    if (!cdt.is_edge(handles[i], handles[(i + 1) % m]))
      throw InternalError("target mesh: the mesher split boundary edge " + std::to_string(i) +
                          " of a piece");
  }

  result.faces.reserve(m - 2 + 2 * result.steiner.size());
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
    if (!f->is_in_domain()) continue;
    if (orient(f->vertex(0)->point(), f->vertex(1)->point(), f->vertex(2)->point()) <= 0)
      throw InternalError("target mesh: the mesher produced a non-positive triangle");
    result.faces.push_back(
        Triangle{f->vertex(0)->info().id, f->vertex(1)->info().id, f->vertex(2)->info().id});
  }
  // A triangulated simple polygon with m boundary and s interior points has m - 2 + 2s triangles; a Steiner
  // point outside the piece or on its boundary breaks the count.
  if (result.faces.size() != m - 2 + 2 * result.steiner.size())
    throw InternalError("target mesh: piece mesh has " + std::to_string(result.faces.size()) +
                        " triangles, expected " + std::to_string(m - 2 + 2 * result.steiner.size()));
  return result;
}

}  // namespace lipmap::detail
