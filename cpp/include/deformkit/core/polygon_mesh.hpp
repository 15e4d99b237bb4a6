#pragma once
// The one polygon mesh every family takes (surface deformers, subdivision, mesh volume; cages
// next): points and faces, checked once at construction, so that what holds one holds a valid mesh.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace deformkit {

class PolygonMesh {
 public:
  PolygonMesh() = default;
  // n points (3 values each) and faces as a flat corner list with offsets: face f is
  // corners[offsets[f] .. offsets[f + 1]). Throws std::invalid_argument naming `points` for a
  // non-finite row, and `faces` for no faces, a face of fewer than 3 corners or a corner index
  // outside 0..n-1. A vertex repeated within a face is left to require_distinct_corners.
  PolygonMesh(const double* points, std::size_t n, const std::vector<std::int64_t>& corners,
              const std::vector<std::int64_t>& offsets);

  std::size_t vertex_count() const { return points_.size() / 3; }
  std::size_t face_count() const { return offsets_.empty() ? 0 : offsets_.size() - 1; }
  std::size_t corner_count() const { return corners_.size(); }
  const std::vector<double>& points() const { return points_; }
  // The vertex of every corner, face after face; face f's corners start at offsets()[f].
  const std::vector<int>& corners() const { return corners_; }
  const std::vector<std::int64_t>& offsets() const { return offsets_; }
  int face_size(std::size_t f) const { return int(offsets_[f + 1] - offsets_[f]); }
  const int* face(std::size_t f) const { return corners_.data() + offsets_[f]; }
  bool all_triangles() const;

  // Every face fanned from its first corner into triangles (c0, ci, ci+1), in face order: the
  // same points, triangles only (a triangle mesh is returned as it is).
  PolygonMesh triangulate() const&;
  PolygonMesh triangulate() &&;

 private:
  std::vector<double> points_;
  std::vector<int> corners_;
  std::vector<std::int64_t> offsets_;
};

// Throws std::invalid_argument "faces: face f repeats vertex v" for the first face (and in it the
// first corner) that visits a vertex twice: the surface deformers and subdivision need simple
// polygons; a volume does not.
void require_distinct_corners(const PolygonMesh& mesh);

// The connected component of each vertex (through faces; an isolated vertex is its own), numbered
// in order of their first vertex; *count gets the number of components.
std::vector<int> connected_components(const PolygonMesh& mesh, int* count);

}  // namespace deformkit
