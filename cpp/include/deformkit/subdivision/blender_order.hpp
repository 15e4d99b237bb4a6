#pragma once
// Blender's Subdivision Surface numbering of a Catmull-Clark subdivision's vertices, edges and faces.
#include "deformkit/subdivision/subdivide.hpp"

#include <cstddef>
#include <vector>

namespace deformkit {

// How Blender's Subdivision Surface modifier numbers what a Subdivider makes
// (docs/subdivision.md, "Blender's order").
struct BlenderOrder {
  std::vector<int> vertex;      // per Subdivider vertex: Blender's index
  std::vector<int> face;        // per Subdivider face: Blender's index
  std::vector<int> face_start;  // per Subdivider face: which of its corners is Blender's first
  std::vector<int> edges;       // Blender's edges in its order, 2 per edge, in Blender's vertex numbers
};

// Blender's order for a Catmull-Clark Subdivider: vertices are the control vertices, then every
// control edge's inner vertices from its first vertex to its second, then each control face's
// inner vertices; edges are every control edge's pieces, then each face's inner edges; faces go
// by control face. `edges` holds the control mesh's edges as Blender numbers and orients them
// (2 per edge): exactly the edges of its faces. Throws std::invalid_argument naming `edges` for
// anything else, or naming `scheme` for a Loop subdivider (Blender's modifier has no Loop).
BlenderOrder blender_order(const Subdivider& subdivider, const int* edges, std::size_t edge_count);

}  // namespace deformkit
