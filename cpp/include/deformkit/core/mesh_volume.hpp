#pragma once
// Signed volume enclosed by a closed polygon mesh.
#include "deformkit/core/polygon_mesh.hpp"

namespace deformkit {

// Divergence theorem: V = 1/6 sum over triangles a . (b x c), polygons fanned from their first
// corner (PolygonMesh::triangulate). Positive for outward-facing winding. Throws
// std::invalid_argument naming `faces` for a face that repeats a vertex (require_distinct_corners)
// and `points` when the volume overflows a double.
double mesh_volume(const PolygonMeshView& mesh);
inline double mesh_volume(const PolygonMesh& mesh) { return mesh_volume(mesh.view()); }

}  // namespace deformkit
