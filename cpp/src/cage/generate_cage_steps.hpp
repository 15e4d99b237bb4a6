#pragma once
// The steps of generate_cage that use CGAL, behind plain arrays: the alpha wrap, the outward
// simplification and the exact check of the result (docs/cage.md, "Generated cages").
#include <array>
#include <cstddef>
#include <vector>

namespace deformkit::cage_generation {

struct TriangleCage {
  std::vector<double> points;
  std::vector<std::array<int, 3>> triangles;
};

// CGAL's 3D alpha wrap (Portaneri, Rouxel-Labbe, Hemmer, Cohen-Steiner, Alliez 2022) of the points,
// segments (degenerate triangles) and triangles of the input.
TriangleCage alpha_wrap(const std::vector<double>& points, const std::vector<std::array<int, 3>>& triangles,
                        double alpha, double offset);

// Edge collapses, cheapest added volume first, each placing its vertex by the progressive-hull
// program and kept only when the new faces meet no other face of the cage: the region only
// grows. Stops at max_faces or when no collapse is left.
TriangleCage simplify_outward(const TriangleCage& wrap, int max_faces);

// Exactly (CGAL's filtered predicates on the doubles): every point strictly inside the closed
// cage and no input triangle, segment or point on or across it.
bool strictly_encloses(const TriangleCage& cage, const std::vector<double>& points,
                       const std::vector<std::array<int, 3>>& triangles);

}  // namespace deformkit::cage_generation
