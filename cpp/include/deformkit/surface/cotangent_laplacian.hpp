#pragma once
// Discrete Laplacians of a mesh, its polygons fanned into triangles (PolygonMesh::triangulate).
#include "deformkit/numerics/sparse.hpp"
#include "deformkit/core/polygon_mesh.hpp"

#include <Eigen/Sparse>

namespace deformkit {

// L_ij = -w_ij, L_ii = sum_j w_ij with w_ij = (cot a_ij + cot b_ij) / 2 (Pinkall-Polthier; Sorkine
// 2004 sec. 2). Each cotangent is clamped to [-kMaxCotangent, kMaxCotangent], so a degenerate
// (zero-area) triangle gives large but finite weights instead of inf or NaN.
constexpr double kMaxCotangent = 1e4;
SparseMatrix cotangent_laplacian(const PolygonMesh& mesh);
// w_ij = 1 for every edge.
SparseMatrix uniform_laplacian(const PolygonMesh& mesh);

}  // namespace deformkit
