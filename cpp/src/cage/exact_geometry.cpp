// The cage family's exact predicates: CGAL's filtered predicates, exact on the input doubles
// (interval arithmetic first, exact arithmetic when the interval cannot decide the sign:
// Bronnimann, Burnikel, Pion 2001, "Interval arithmetic yields efficient dynamic filters").
#include "cage/exact_geometry.hpp"

#include "deformkit/cage/cage_mesh.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Intersections_3/Segment_3_Triangle_3.h>
#include <CGAL/Intersections_3/Triangle_3_Triangle_3.h>

#include <algorithm>
#include <cstddef>
#include <numeric>
#include <vector>

namespace deformkit {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;

Point point_of(const std::vector<double>& p, int v) { return Point(p[3 * v], p[3 * v + 1], p[3 * v + 2]); }

// The vertices two triangles a and b share by index, each as its corner in a and its corner in b.
struct SharedCorners {
  int count = 0;
  int in_a[3] = {0, 0, 0}, in_b[3] = {0, 0, 0};  // for each shared vertex: its corner in a, in b
};

SharedCorners shared_corners(const CageTriangle& a, const CageTriangle& b) {
  SharedCorners s;
  for (int u = 0; u < 3; ++u)
    for (int w = 0; w < 3; ++w)
      if (a[u] == b[w]) s.in_a[s.count] = u, s.in_b[s.count] = w, ++s.count;
  return s;
}

// Whether two closed triangles meet anywhere but in the vertices and edges they share by index.
// Sharing an edge: only when coplanar and folded onto the same side of it. Sharing one vertex v:
// their intersection is convex and holds v, so it leaves v exactly when one triangle meets the edge
// of the other that is opposite v (on the planes' common line the shorter of the two pieces from v
// ends on such an edge; in a common plane, along any direction both cover).
bool meet_beyond_shared(const std::vector<double>& p, const CageTriangle& a, const CageTriangle& b) {
  const SharedCorners s = shared_corners(a, b);
  const Point pa[3] = {point_of(p, a[0]), point_of(p, a[1]), point_of(p, a[2])};
  const Point pb[3] = {point_of(p, b[0]), point_of(p, b[1]), point_of(p, b[2])};
  const Kernel::Triangle_3 ta(pa[0], pa[1], pa[2]), tb(pb[0], pb[1], pb[2]);
  if (s.count == 3) return true;  // the same triangle twice: it overlaps itself everywhere
  if (s.count == 2) {
    const Point& u = pa[s.in_a[0]];
    const Point& w = pa[s.in_a[1]];
    const Point& ra = pa[3 - s.in_a[0] - s.in_a[1]];
    const Point& rb = pb[3 - s.in_b[0] - s.in_b[1]];
    return CGAL::coplanar(u, w, ra, rb) && CGAL::coplanar_orientation(u, w, ra, rb) == CGAL::POSITIVE;
  }
  if (s.count == 1) {
    const int i = s.in_a[0], j = s.in_b[0];
    return CGAL::do_intersect(tb, Kernel::Segment_3(pa[(i + 1) % 3], pa[(i + 2) % 3])) ||
           CGAL::do_intersect(ta, Kernel::Segment_3(pb[(j + 1) % 3], pb[(j + 2) % 3]));
  }
  return CGAL::do_intersect(ta, tb);
}

}  // namespace

namespace cage_exact {

int turn_along(const Vec3& a, const Vec3& b, const Vec3& c, int axis) {
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;  // (u, v, axis) is right-handed
  return int(CGAL::orientation(Kernel::Point_2(a[u], a[v]), Kernel::Point_2(b[u], b[v]), Kernel::Point_2(c[u], c[v])));
}

}  // namespace cage_exact

std::array<int, 2> first_intersecting_triangles(const std::vector<double>& points,
                                                const std::vector<CageTriangle>& triangles) {
  const std::size_t t = triangles.size();
  std::vector<CGAL::Bbox_3> boxes(t);
  for (std::size_t i = 0; i < t; ++i) {
    const Point a = point_of(points, triangles[i][0]), b = point_of(points, triangles[i][1]),
                c = point_of(points, triangles[i][2]);
    // A segment or a point is no triangle to test against: it counts as meeting itself.
    if (CGAL::collinear(a, b, c)) return {int(i), int(i)};
    boxes[i] = a.bbox() + b.bbox() + c.bbox();  // the doubles themselves: exact
  }
  // Candidates: the pairs whose closed boxes meet (touching counts), found by a sweep along the
  // axis the cage is longest on. CGAL's box_self_intersection_d would do as well, but it is GPL
  // where the kernel is LGPL (docs/install.md, "Licences").
  const CGAL::Bbox_3 all = std::accumulate(boxes.begin(), boxes.end(), CGAL::Bbox_3());
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (all.max(k) - all.min(k) > all.max(axis) - all.min(axis)) axis = k;
  std::vector<std::size_t> order(t);
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::sort(order.begin(), order.end(), [&](std::size_t i, std::size_t j) { return boxes[i].min(axis) < boxes[j].min(axis); });
  std::array<int, 2> first{-1, -1};
  for (std::size_t m = 0; m < t; ++m) {
    const CGAL::Bbox_3& x = boxes[order[m]];
    for (std::size_t n = m + 1; n < t && boxes[order[n]].min(axis) <= x.max(axis); ++n) {
      if (!CGAL::do_overlap(x, boxes[order[n]])) continue;
      const int i = int(std::min(order[m], order[n])), j = int(std::max(order[m], order[n]));
      const bool earlier = first[0] < 0 || i < first[0] || (i == first[0] && j < first[1]);
      if (earlier && meet_beyond_shared(points, triangles[std::size_t(i)], triangles[std::size_t(j)])) first = {i, j};
    }
  }
  return first;
}

}  // namespace deformkit
