#pragma once
// The grid system as the solver walks it: unknowns in cell order, each with the indices of its six
// neighbours, and the block vectors of several right-hand sides stored row by row.
#include "deformkit/numerics/grid_stencil.hpp"

#include <array>
#include <cstddef>
#include <vector>

namespace deformkit::numerics {

// `width` right-hand sides interleaved: row u's values are contiguous, so one pass over the stencil
// serves every column (the kernels are bound by memory traffic). Row `rows` stays zero: absent
// neighbours point at it, which keeps the stencil loops free of branches.
template <class T>
struct BlockOf {
  std::size_t rows = 0;
  int width = 0;
  std::vector<T> data;

  void resize(std::size_t r, int w) {
    rows = r, width = w;
    data.assign((r + 1) * std::size_t(w), T(0));
  }
  T* row(std::size_t u) { return data.data() + u * std::size_t(width); }
  const T* row(std::size_t u) const { return data.data() + u * std::size_t(width); }
};
using Block = BlockOf<double>;

// A level's coefficients rounded for the multigrid cycle, which runs in single precision.
struct SingleCoefficients {
  std::vector<float> diagonal, inverse_diagonal;
  std::vector<std::array<float, 6>> coupling;
};

struct StencilLevel {
  std::array<int, 3> cells{};
  std::size_t size = 0;                       // unknowns
  std::vector<int> cell;                      // per unknown, ascending
  std::vector<double> diagonal, inverse_diagonal;
  std::vector<std::array<int, 6>> neighbour;  // -x,+x,-y,+y,-z,+z: an unknown, or `size` (the zero row)
  std::vector<std::array<double, 6>> coupling;
  std::array<std::vector<int>, 2> colour;     // unknowns with i + j + k even, odd
  SingleCoefficients single;
  // Towards the next coarser level (empty on the coarsest).
  std::vector<int> parent;                    // per unknown: its 2x2x2 aggregate there
  std::vector<int> child_start, child;        // per aggregate: its unknowns here, colour 0 first
  std::vector<int> colour0_end;               // per aggregate: where its colour-0 unknowns end in child
};

// Fills a.single from the double coefficients.
void round_to_single(StencilLevel& a);

// Checks `system` (std::invalid_argument naming what is wrong) and renumbers its unknowns in cell
// order; external[u] is the caller's index of unknown u.
StencilLevel checked_fine_level(const GridStencil& system, std::vector<int>& external);

// The Galerkin operator P^T A P of piecewise constant interpolation on 2x2x2 aggregates: again a
// 7-point stencil, its cut-edge weights kept on the diagonal. Fills fine.parent and fine.child*.
StencilLevel aggregated_level(StencilLevel& fine);

}  // namespace deformkit::numerics
