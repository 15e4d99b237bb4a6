#pragma once
// Signed volume enclosed by a closed polygon mesh.
#include <cstddef>
#include <cstdint>

namespace deformkit {

// Divergence theorem: V = 1/6 sum over triangles a . (b x c), polygons fanned from their first
// corner. faces: m x k row-major corner indices (k >= 3). Positive for outward-facing winding.
// Throws std::invalid_argument naming `faces` for an index out of range.
double mesh_volume(const double* points, std::size_t n, const std::int64_t* faces, std::size_t m, std::size_t k);

}  // namespace deformkit
