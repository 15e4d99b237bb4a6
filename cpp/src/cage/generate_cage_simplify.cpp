// Outward simplification of a wrap: CGAL's edge collapse (Lindstrom and Turk's framework) with
// progressive-hull placement (Sander et al. 2000, "Silhouette clipping", Sec. 4: the new vertex
// lies outside the plane of every face around the edge, so the coarser surface encloses the
// finer) and a filter that keeps the cage free of self-intersections, both decided exactly.
#include "cage/generate_cage_hull.hpp"
#include "cage/generate_cage_steps.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Edge_collapse_visitor_base.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace deformkit::cage_generation {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
using VertexId = Mesh::Vertex_index;
using FaceId = Mesh::Face_index;
namespace SMS = CGAL::Surface_mesh_simplification;
using Profile = SMS::Edge_profile<Mesh>;

Vec3 vec(const Point& p) { return Vec3(p.x(), p.y(), p.z()); }

// A triangle by its vertices, the collapsed vertex written as `kNew`.
constexpr std::uint32_t kNew = 0xffffffffu;
struct Tri {
  std::array<std::uint32_t, 3> v;
  std::array<Point, 3> p;
};

// Whether two closed triangles meet beyond the vertices and the edge they share by index: sharing
// an edge, only when coplanar and folded onto one side; sharing a vertex, exactly when one meets
// the other's edge opposite it (the cage family's rule, docs/cage.md, "Cage validity"). Coplanar
// pairs sharing one vertex are refused outright: a collapse can do without them.
bool meet_beyond_shared(const Tri& a, const Tri& b) {
  int shared = 0, ia[3], ib[3];
  for (int u = 0; u < 3; ++u)
    for (int w = 0; w < 3; ++w)
      if (a.v[u] == b.v[w]) ia[shared] = u, ib[shared] = w, ++shared;
  if (shared == 3) return true;
  if (shared == 2) {
    const Point& ra = a.p[3 - ia[0] - ia[1]];
    const Point& rb = b.p[3 - ib[0] - ib[1]];
    const Point &u = a.p[ia[0]], &w = a.p[ia[1]];
    return CGAL::coplanar(u, w, ra, rb) && CGAL::coplanar_orientation(u, w, ra, rb) != CGAL::NEGATIVE;
  }
  const Kernel::Triangle_3 ta(a.p[0], a.p[1], a.p[2]), tb(b.p[0], b.p[1], b.p[2]);
  if (shared == 1) {
    const int i = ia[0], j = ib[0];
    if (CGAL::coplanar(a.p[0], a.p[1], a.p[2], b.p[(j + 1) % 3]) && CGAL::coplanar(a.p[0], a.p[1], a.p[2], b.p[(j + 2) % 3]))
      return true;
    return CGAL::do_intersect(tb, Kernel::Segment_3(a.p[(i + 1) % 3], a.p[(i + 2) % 3])) ||
           CGAL::do_intersect(ta, Kernel::Segment_3(b.p[(j + 1) % 3], b.p[(j + 2) % 3]));
  }
  return CGAL::do_intersect(ta, tb);
}

// The cage's faces in a uniform grid of cells; entries go stale as faces move and are checked
// against the current geometry on every query, then the grid is rebuilt coarser as faces grow.
class FaceGrid {
 public:
  void rebuild(const Mesh& m) {
    double total = 0;
    std::size_t count = 0;
    for (auto e : m.edges()) {
      total += std::sqrt(CGAL::squared_distance(m.point(m.vertex(e, 0)), m.point(m.vertex(e, 1))));
      ++count;
    }
    cell_ = std::max(2.0 * total / double(std::max<std::size_t>(count, 1)), 1e-300);
    cells_.clear();
    stamp_.assign(m.number_of_faces() + m.number_of_removed_faces(), 0);
    for (auto f : m.faces()) insert(m, f);
  }
  void insert(const Mesh& m, FaceId f) {
    const CGAL::Bbox_3 box = box_of(m, f);
    for_cells(box, [&](std::uint64_t key) { cells_[key].push_back(std::uint32_t(f)); });
  }
  template <class F>
  void visit(const CGAL::Bbox_3& box, F&& f) {
    ++query_;
    for_cells(box, [&](std::uint64_t key) {
      const auto it = cells_.find(key);
      if (it == cells_.end()) return;
      for (std::uint32_t g : it->second)
        if (stamp_[g] != query_) stamp_[g] = query_, f(FaceId(g));
    });
  }
  static CGAL::Bbox_3 box_of(const Mesh& m, FaceId f) {
    CGAL::Bbox_3 b;
    for (auto v : CGAL::vertices_around_face(m.halfedge(f), m)) b += m.point(v).bbox();
    return b;
  }

 private:
  template <class F>
  void for_cells(const CGAL::Bbox_3& b, F&& f) const {
    std::int64_t lo[3], hi[3];
    for (int k = 0; k < 3; ++k)
      lo[k] = std::int64_t(std::floor(b.min(k) / cell_)), hi[k] = std::int64_t(std::floor(b.max(k) / cell_));
    for (std::int64_t i = lo[0]; i <= hi[0]; ++i)
      for (std::int64_t j = lo[1]; j <= hi[1]; ++j)
        for (std::int64_t k = lo[2]; k <= hi[2]; ++k)
          f(std::uint64_t(i & 0x1fffff) | std::uint64_t(j & 0x1fffff) << 21 | std::uint64_t(k & 0x1fffff) << 42);
  }
  double cell_ = 1.0;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells_;
  std::vector<std::uint32_t> stamp_;
  std::uint32_t query_ = 0;
};

// The faces around an edge (v0, v1) before its collapse, each with its corners in order.
std::vector<std::array<VertexId, 3>> star_of(const Mesh& m, VertexId v0, VertexId v1, std::vector<FaceId>* ids = nullptr) {
  std::vector<std::array<VertexId, 3>> star;
  std::vector<FaceId> seen;
  for (VertexId v : {v0, v1})
    for (auto f : CGAL::faces_around_target(m.halfedge(v), m)) {
      if (f == Mesh::null_face() || std::find(seen.begin(), seen.end(), f) != seen.end()) continue;
      seen.push_back(f);
      std::array<VertexId, 3> t;
      int k = 0;
      for (auto u : CGAL::vertices_around_face(m.halfedge(f), m)) t[std::size_t(k++)] = u;
      star.push_back(t);
    }
  if (ids) *ids = seen;
  return star;
}

bool holds(const std::array<VertexId, 3>& t, VertexId v) { return t[0] == v || t[1] == v || t[2] == v; }

// Six times the volume enclosed by the faces around an edge, as a function of where the
// collapsed vertex x goes: objective . x + constant, since det(x, q, r) = x . (q x r) for each face
// that stays, and old_volume: what the faces enclose now.
struct StarVolume {
  Vec3 objective = Vec3::Zero();
  double old_volume = 0;
};

StarVolume star_volume(const Mesh& m, VertexId v0, VertexId v1, const std::vector<std::array<VertexId, 3>>& star) {
  StarVolume s;
  for (const auto& t : star) {
    const Vec3 a = vec(m.point(t[0])), b = vec(m.point(t[1])), c = vec(m.point(t[2]));
    s.old_volume += a.dot(b.cross(c));
    if (holds(t, v0) && holds(t, v1)) continue;  // removed by the collapse
    const int k = (t[0] == v0 || t[0] == v1) ? 0 : (t[1] == v0 || t[1] == v1) ? 1 : 2;
    s.objective += vec(m.point(t[(k + 1) % 3])).cross(vec(m.point(t[(k + 2) % 3])));
  }
  return s;
}

// The progressive-hull program for one edge: outside every face plane by a margin that the
// rounding of the result cannot undo, inside a box around the edge.
std::optional<Vec3> hull_placement(const Mesh& m, VertexId v0, VertexId v1, double margin) {
  const auto star = star_of(m, v0, v1);
  std::vector<HalfSpace> outside;
  for (const auto& t : star) {
    const Vec3 a = vec(m.point(t[0])), b = vec(m.point(t[1])), c = vec(m.point(t[2]));
    const Vec3 n = (b - a).cross(c - a);
    const double len = n.norm();
    if (!(len > 0)) return std::nullopt;
    outside.push_back({n / len, n.dot(a) / len + margin});
  }
  const Vec3 p0 = vec(m.point(v0)), p1 = vec(m.point(v1));
  const double reach = (p1 - p0).norm() + 4 * margin;
  const Vec3 lo = p0.cwiseMin(p1) - Vec3::Constant(reach), hi = p0.cwiseMax(p1) + Vec3::Constant(reach);
  return lowest_point(star_volume(m, v0, v1, star).objective, outside, lo, hi);
}

struct HullPlacement {
  double margin;
  boost::optional<Point> operator()(const Profile& profile) const {
    const auto x = hull_placement(profile.surface_mesh(), profile.v0(), profile.v1(), margin);
    if (!x) return boost::none;
    return Point((*x)[0], (*x)[1], (*x)[2]);
  }
};

// The added volume, and a little of the edge's length cubed so that among free collapses (flat
// regions) the short edges go first and faces stay well shaped.
struct HullCost {
  boost::optional<double> operator()(const Profile& profile, const boost::optional<Point>& placement) const {
    if (!placement) return boost::none;
    const Mesh& m = profile.surface_mesh();
    const StarVolume s = star_volume(m, profile.v0(), profile.v1(), star_of(m, profile.v0(), profile.v1()));
    const double added = std::max(0.0, (s.objective.dot(vec(*placement)) - s.old_volume) / 6.0);
    const double len = std::sqrt(CGAL::squared_distance(profile.p0(), profile.p1()));
    return added + 1e-3 * len * len * len;
  }
};

// Accepts a collapse only if, exactly, the new vertex is strictly outside every old face's plane,
// no new face is degenerate and no new face meets another face of the cage.
struct OutwardFilter {
  FaceGrid* grid;
  boost::optional<Point> operator()(const Profile& profile, boost::optional<Point> placement) const {
    if (!placement) return boost::none;
    const Mesh& m = profile.surface_mesh();
    const VertexId v0 = profile.v0(), v1 = profile.v1();
    std::vector<FaceId> star_ids;
    const auto star = star_of(m, v0, v1, &star_ids);
    const Point& x = *placement;
    std::vector<Tri> fresh;
    CGAL::Bbox_3 box;
    for (const auto& t : star) {
      if (CGAL::orientation(m.point(t[0]), m.point(t[1]), m.point(t[2]), x) != CGAL::POSITIVE) return boost::none;
      if (holds(t, v0) && holds(t, v1)) continue;
      Tri n;
      for (int k = 0; k < 3; ++k) {
        const bool moved = t[k] == v0 || t[k] == v1;
        n.v[k] = moved ? kNew : std::uint32_t(t[k]);
        n.p[k] = moved ? x : m.point(t[k]);
      }
      if (CGAL::collinear(n.p[0], n.p[1], n.p[2])) return boost::none;
      box += n.p[0].bbox() + n.p[1].bbox() + n.p[2].bbox();
      fresh.push_back(n);
    }
    for (std::size_t i = 0; i < fresh.size(); ++i)
      for (std::size_t j = i + 1; j < fresh.size(); ++j)
        if (meet_beyond_shared(fresh[i], fresh[j])) return boost::none;
    bool clear = true;
    grid->visit(box, [&](FaceId g) {
      if (!clear || m.is_removed(g) || std::find(star_ids.begin(), star_ids.end(), g) != star_ids.end()) return;
      const CGAL::Bbox_3 gb = FaceGrid::box_of(m, g);
      if (!CGAL::do_overlap(gb, box)) return;
      Tri other;
      int k = 0;
      for (auto u : CGAL::vertices_around_face(m.halfedge(g), m)) {
        other.v[std::size_t(k)] = std::uint32_t(u);
        other.p[std::size_t(k++)] = m.point(u);
      }
      for (const Tri& n : fresh)
        if (CGAL::do_overlap(n.p[0].bbox() + n.p[1].bbox() + n.p[2].bbox(), gb) && meet_beyond_shared(n, other)) {
          clear = false;
          return;
        }
    });
    return clear ? placement : boost::none;
  }
};

struct GridKeeper : SMS::Edge_collapse_visitor_base<Mesh> {
  FaceGrid* grid;
  std::size_t* faces_alive;
  std::size_t faces_at_build;
  void OnCollapsed(const Profile& profile, VertexId kept) {
    *faces_alive -= 2;
    const Mesh& m = profile.surface_mesh();
    if (2 * *faces_alive < faces_at_build) {
      grid->rebuild(m);
      faces_at_build = *faces_alive;
      return;
    }
    for (auto f : CGAL::faces_around_target(m.halfedge(kept), m))
      if (f != Mesh::null_face()) grid->insert(m, f);
  }
};

struct FaceBudget {
  std::size_t max_faces;
  template <class F, class P>
  bool operator()(const F&, const P&, std::size_t, std::size_t edges) const {
    return 2 * edges <= 3 * max_faces;  // a closed triangle mesh has 3 F = 2 E
  }
};

}  // namespace

TriangleCage simplify_outward(const TriangleCage& wrap, int max_faces) {
  Mesh m;
  std::vector<VertexId> v;
  double scale = 0;
  for (std::size_t i = 0; i < wrap.points.size() / 3; ++i) {
    v.push_back(m.add_vertex(Point(wrap.points[3 * i], wrap.points[3 * i + 1], wrap.points[3 * i + 2])));
    for (int k = 0; k < 3; ++k) scale = std::max(scale, std::abs(wrap.points[3 * i + std::size_t(k)]));
  }
  for (const auto& t : wrap.triangles) m.add_face(v[std::size_t(t[0])], v[std::size_t(t[1])], v[std::size_t(t[2])]);
  // Far above the rounding of a coordinate, far below any distance that matters.
  const double margin = 1e-9 * scale;
  FaceGrid grid;
  grid.rebuild(m);
  std::size_t alive = m.number_of_faces();
  GridKeeper keeper;
  keeper.grid = &grid;
  keeper.faces_alive = &alive;
  keeper.faces_at_build = alive;
  SMS::edge_collapse(m, FaceBudget{std::size_t(max_faces)},
                     CGAL::parameters::get_cost(HullCost{})
                         .get_placement(HullPlacement{margin})
                         .filter(OutwardFilter{&grid})
                         .visitor(keeper));
  m.collect_garbage();
  TriangleCage out;
  for (auto u : m.vertices()) {
    const Point& p = m.point(u);
    out.points.insert(out.points.end(), {p.x(), p.y(), p.z()});
  }
  for (auto f : m.faces()) {
    std::array<int, 3> t{};
    int k = 0;
    for (auto u : CGAL::vertices_around_face(m.halfedge(f), m)) t[std::size_t(k++)] = int(std::size_t(u));
    out.triangles.push_back(t);
  }
  return out;
}

}  // namespace deformkit::cage_generation
