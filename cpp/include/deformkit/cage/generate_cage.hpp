#pragma once
// A coarse cage made for a mesh (docs/cage.md, "Generated cages"): CGAL's 3D alpha wrap of the
// mesh at an offset, then edge collapses that only ever grow the enclosed region (progressive
// hulls), down to a face budget.
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace deformkit {

struct CageGenerationOptions {
  int max_faces = 200;     // at least 4 (a tetrahedron)
  double offset = 0.0;     // the wrap's distance from the mesh; 0: the default, diagonal / 100
  double alpha = 0.0;      // the wrap's detail (the smallest gap it enters); 0: the default, (diagonal + 2 offset) / clamp(1.2 sqrt(max_faces), 4, 20)
  bool quads = false;      // merge triangle pairs into quads where the cage deformers split them back alike
};

struct GeneratedCage {
  std::vector<double> points;          // 3 values a vertex
  std::vector<int> corners;            // face after face
  std::vector<std::int64_t> offsets;   // face f is corners[offsets[f] .. offsets[f + 1])
  std::size_t wrap_faces = 0;          // the alpha wrap's triangles, before simplification
  double alpha = 0.0, offset = 0.0;    // the values used (after defaults and any coarsening)
  std::size_t face_count() const { return offsets.empty() ? 0 : offsets.size() - 1; }
};

// A closed, 2-manifold, outward-oriented, self-intersection-free triangle (or quad-dominant) cage
// of at most options.max_faces faces whose inside holds every point and every triangle of the
// input, touching none of them. `triangles` may be empty (a point cloud), degenerate (segments,
// points), open, non-manifold or self-intersecting. Throws std::invalid_argument naming `points`
// (none, or not finite), `faces` (an index out of range), `max_faces` (below 4), `offset` or
// `alpha` (not positive and finite).
GeneratedCage generate_cage(const std::vector<double>& points, const std::vector<std::array<int, 3>>& triangles,
                            const CageGenerationOptions& options = {});

}  // namespace deformkit
