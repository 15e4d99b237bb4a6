#pragma once
// A cage: a closed, consistently oriented polygon mesh around the points it deforms, checked once
// and split into outward-facing triangles by a rule of its geometry (docs/math/cage.md,
// "Splitting polygons into triangles").
#include "deformkit/core/polygon_mesh.hpp"

#include <array>
#include <cstddef>
#include <vector>

namespace deformkit {

using CageTriangle = std::array<int, 3>;

// The triangles of one polygon of `count` corners (vertex indices into points, 3 values each),
// in the polygon's orientation: ears cut one by one, each time the ear of non-degenerate area
// whose closing diagonal is shortest (ties: the diagonal of the smaller vertex pair). An ear's
// turns are exact signs seen along the axis the polygon's vector area leans on most, so a planar
// simple polygon always splits validly, whatever its placement. Each triangle
// starts at its smallest vertex and the polygon's triangles are sorted, so the result depends on
// the polygon's vertices and their cyclic order only, not on which corner the face lists first.
// Empty when no ear of non-zero area is left (a degenerate polygon).
std::vector<CageTriangle> split_polygon(const double* points, const int* corners, int count);

class CageMesh {
 public:
  CageMesh() = default;
  // Throws std::invalid_argument naming `points` or `faces` (PolygonMesh's checks: a non-finite
  // point, an index out of range) and then `faces` for the first face that repeats a vertex or has
  // zero area, then for the first edge (in face order) that is non-manifold (more than two faces),
  // runs the same way in two faces (inconsistent orientation) or has one face only (an open cage),
  // then for a cage that encloses no volume and for the first pair of triangles that meet beyond
  // the vertices and edge they share (first_intersecting_triangles): their polygons are named.
  // A cage whose faces point inward (negative signed volume) is flipped: flipped() is then true.
  explicit CageMesh(PolygonMesh polygons);

  std::size_t vertex_count() const { return polygons_.vertex_count(); }
  const std::vector<double>& rest_points() const { return polygons_.points(); }
  // The polygons as given (their orientation as given, also when flipped).
  const PolygonMesh& polygons() const { return polygons_; }
  // Outward-facing triangles, polygon after polygon; triangle_face()[t] is triangle t's polygon.
  const std::vector<CageTriangle>& triangles() const { return triangles_; }
  const std::vector<int>& triangle_face() const { return triangle_face_; }
  bool flipped() const { return flipped_; }
  // The enclosed volume (positive: after any flip).
  double volume() const { return volume_; }
  // max(bounding-box diagonal, largest coordinate magnitude): the length that on-cage tolerances
  // are relative to (a point's coordinates are rounded relative to their magnitude).
  double length_scale() const { return length_scale_; }

 private:
  PolygonMesh polygons_;
  std::vector<CageTriangle> triangles_;
  std::vector<int> triangle_face_;
  bool flipped_ = false;
  double volume_ = 0.0;
  double length_scale_ = 0.0;
};

// The first pair (in triangle order) of triangles of `triangles` that have a point in common
// besides the vertices and the edge they share by index, touching included, or {-1, -1}; {t, t}
// for a triangle whose corners are collinear. Decided exactly on the input doubles (CGAL's exact
// predicates), testing only the pairs whose closed bounding boxes meet.
std::array<int, 2> first_intersecting_triangles(const std::vector<double>& points,
                                                const std::vector<CageTriangle>& triangles);

}  // namespace deformkit
