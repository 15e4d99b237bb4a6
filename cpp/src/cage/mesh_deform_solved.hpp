#pragma once
// What a MeshDeform keeps of its grid: the grid, its system, and for a dynamic bind each cell's
// coordinates (shared by the bind in mesh_deform.cpp and the evaluation in mesh_deform_eval.cpp).
#include "cage/harmonic_grid.hpp"
#include "deformkit/cage/mesh_deform.hpp"

#include <cstdint>
#include <vector>

namespace deformkit::harmonic {

struct Solved {
  Solved(const CageMesh& c, int precision, int bvh_arity, GridSolver solver)
      : solver(solver), cage(c), rays(cage, bvh_arity), grid(build_grid(rays, cage.rest_points(), precision)), stencil(grid_stencil(grid)),
        terms(boundary_terms(grid, stencil)) {}
  GridSolver solver;
  CageMesh cage;  // a copy: rays reads its polygons
  RayCage rays;
  HarmonicGrid grid;
  numerics::GridStencil stencil;
  std::vector<BoundaryTerm> terms;
  // Dynamic: each cell's influences (cage vertex, weight), normalised per cell, as CSR.
  std::vector<std::uint32_t> cell_start;
  std::vector<std::int32_t> cell_vertex;
  std::vector<double> cell_weight;
};

}  // namespace deformkit::harmonic
