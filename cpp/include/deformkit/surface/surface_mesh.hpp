#pragma once
// A triangle mesh for the surface deformers: polygons fanned into triangles, checked.
#include <cstdint>
#include <vector>

namespace deformkit {

struct TriangleMesh {
  std::vector<double> points;  // 3n
  std::vector<int> triangles;  // 3t
  std::size_t vertex_count() const { return points.size() / 3; }
  std::size_t triangle_count() const { return triangles.size() / 3; }
};

// Polygons as a flat corner list with offsets (polygon f is corners[offsets[f] .. offsets[f+1])),
// fanned from their first corner. Throws std::invalid_argument naming `faces` for fewer than 3
// corners, an index out of range or a repeated vertex, and `points` for non-finite points.
TriangleMesh triangulate(const double* points, std::size_t n, const std::vector<std::int64_t>& corners,
                         const std::vector<std::int64_t>& offsets);

// Connected component of each vertex (through triangles); isolated vertices are their own.
std::vector<int> connected_components(const TriangleMesh& mesh, int* count);

}  // namespace deformkit
