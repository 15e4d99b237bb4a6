#pragma once
// Green coordinates of many points at once, SIMD lanes over points: the closed form of
// green_coordinates.cpp evaluated for a vector of points per cage triangle, with what does not
// depend on the point computed once per cage (docs/math/green_coordinates.md, "Binding many points").
#include "cage/green_coordinates.hpp"

#include <cstddef>
#include <vector>

namespace deformkit {

// The cage's point-independent terms: per undirected edge its ends (lo < hi, vertex indices),
// unit direction lo -> hi and length; per triangle its unit normal, hat-function gradients g_l and
// outward in-plane edge normals m_k, computed exactly as the single-point code computes them.
struct GreenCageTables {
  struct Edge {
    int lo = 0, hi = 0;
    double direction[3] = {0, 0, 0};
    double length = 0;
  };
  struct Triangle {
    int vertex[3] = {0, 0, 0};
    int edge[3] = {0, 0, 0};  // edge k runs from vertex k to vertex k + 1
    double normal[3] = {0, 0, 0};
    double gradient[3][3] = {};     // g_l, the gradient of vertex l's hat function
    double edge_normal[3][3] = {};  // m_k
    bool degenerate = false;        // zero area: carries no measure
  };
  std::vector<Edge> edges;
  std::vector<Triangle> triangles;
};

GreenCageTables green_cage_tables(const TriangleCageView& cage);

// Rows of Green coordinates (phi, then psi: m + t per row) of n points (n x 3), equal to
// green_coordinates() without gradients to rounding. Points on the cage's edges, vertices or in a
// face's plane take the single-point code, as do the exterior extension's terms. Not parallel:
// the caller splits the points between threads.
void green_coordinate_rows(const double* points, std::size_t n, const TriangleCageView& cage,
                           const GreenCageTables& tables, double* rows);

}  // namespace deformkit
