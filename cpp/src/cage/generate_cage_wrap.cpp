// The alpha wrap of any input and the exact check that a cage strictly encloses it. The wrap is
// CGAL's (Portaneri et al. 2022, "Alpha wrapping with an offset"); its oracles are stacked so
// that points and segments (degenerate triangles) are wrapped as well as triangles.
#include "cage/generate_cage_steps.hpp"

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/alpha_wrap_3.h>

#include <algorithm>
#include <cstddef>

namespace deformkit::cage_generation {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
namespace aw3 = CGAL::Alpha_wraps_3::internal;
using PointOracle = aw3::Point_set_oracle<Kernel>;
using SegmentOracle = aw3::Segment_soup_oracle<Kernel, PointOracle>;
using TriangleOracle = aw3::Triangle_soup_oracle<Kernel, SegmentOracle>;

Point point_of(const std::vector<double>& p, int v) { return Point(p[3 * v], p[3 * v + 1], p[3 * v + 2]); }

// What a triangle of the input is: a triangle, a segment (its two farthest corners) or a point.
struct Piece {
  int kind = 3;  // 3, 2 or 1 distinct places
  Point a, b, c;
};

Piece piece_of(const std::vector<double>& p, const std::array<int, 3>& t) {
  Piece s{3, point_of(p, t[0]), point_of(p, t[1]), point_of(p, t[2])};
  if (!CGAL::collinear(s.a, s.b, s.c)) return s;
  if (s.a == s.b && s.b == s.c) return Piece{1, s.a, s.a, s.a};
  // Collinear: the two extreme points span the segment.
  const Point q[3] = {s.a, s.b, s.c};
  int i = 0, j = 1;
  for (int u = 0; u < 3; ++u)
    for (int w = u + 1; w < 3; ++w)
      if (CGAL::squared_distance(q[u], q[w]) > CGAL::squared_distance(q[i], q[j])) i = u, j = w;
  return Piece{2, q[i], q[j], q[j]};
}

Mesh mesh_of(const TriangleCage& cage) {
  Mesh m;
  std::vector<Mesh::Vertex_index> v;
  for (std::size_t i = 0; i < cage.points.size() / 3; ++i) v.push_back(m.add_vertex(point_of(cage.points, int(i))));
  for (const auto& t : cage.triangles) m.add_face(v[t[0]], v[t[1]], v[t[2]]);
  return m;
}

}  // namespace

TriangleCage alpha_wrap(const std::vector<double>& points, const std::vector<std::array<int, 3>>& triangles,
                        double alpha, double offset) {
  const std::size_t n = points.size() / 3;
  std::vector<Point> all(n);
  for (std::size_t i = 0; i < n; ++i) all[i] = point_of(points, int(i));
  std::vector<char> covered(n, 0);
  std::vector<std::array<std::size_t, 3>> faces;
  std::vector<Kernel::Segment_3> segments;
  for (const auto& t : triangles) {
    const Piece s = piece_of(points, t);
    if (s.kind == 3) {
      faces.push_back({std::size_t(t[0]), std::size_t(t[1]), std::size_t(t[2])});
      for (int v : t) covered[std::size_t(v)] = 1;
    } else if (s.kind == 2) {
      segments.emplace_back(s.a, s.b);
      for (int v : t) covered[std::size_t(v)] = 1;
    }
  }
  // The points no triangle or segment holds; the leaf oracle must not be empty, so at least one.
  std::vector<Point> loose;
  for (std::size_t i = 0; i < n; ++i)
    if (!covered[i]) loose.push_back(all[i]);
  if (loose.empty()) loose.push_back(all[0]);

  PointOracle point_oracle{Kernel()};
  point_oracle.add_point_set(loose);
  SegmentOracle segment_oracle(point_oracle, Kernel());
  segment_oracle.add_segment_soup(segments);
  TriangleOracle oracle(alpha, segment_oracle, Kernel());
  oracle.add_triangle_soup(all, faces);
  aw3::Alpha_wrap_3<TriangleOracle> wrapper(oracle);
  Mesh wrap;
  wrapper(alpha, offset, wrap);

  TriangleCage out;
  std::vector<int> index(wrap.number_of_vertices() + wrap.number_of_removed_vertices(), -1);
  for (auto v : wrap.vertices()) {
    index[std::size_t(v)] = int(out.points.size() / 3);
    const Point& p = wrap.point(v);
    out.points.insert(out.points.end(), {p.x(), p.y(), p.z()});
  }
  for (auto f : wrap.faces()) {
    std::array<int, 3> t{};
    int k = 0;
    for (auto v : CGAL::vertices_around_face(wrap.halfedge(f), wrap)) t[std::size_t(k++)] = index[std::size_t(v)];
    out.triangles.push_back(t);
  }
  return out;
}

bool strictly_encloses(const TriangleCage& cage, const std::vector<double>& points,
                       const std::vector<std::array<int, 3>>& triangles) {
  const Mesh m = mesh_of(cage);
  using Primitive = CGAL::AABB_face_graph_triangle_primitive<Mesh>;
  using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;
  Tree tree(faces(m).first, faces(m).second, m);
  tree.accelerate_distance_queries();
  const CGAL::Side_of_triangle_mesh<Mesh, Kernel> side(tree);
  for (std::size_t i = 0; i < points.size() / 3; ++i)
    if (side(point_of(points, int(i))) != CGAL::ON_BOUNDED_SIDE) return false;
  for (const auto& t : triangles) {
    const Piece s = piece_of(points, t);
    if (s.kind == 3 && tree.do_intersect(Kernel::Triangle_3(s.a, s.b, s.c))) return false;
    if (s.kind == 2 && tree.do_intersect(Kernel::Segment_3(s.a, s.b))) return false;
  }
  return true;
}

}  // namespace deformkit::cage_generation
