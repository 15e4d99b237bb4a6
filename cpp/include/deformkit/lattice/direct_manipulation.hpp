#pragma once
// Direct manipulation of a lattice (Hsu, Hughes and Kaufman 1992): the smallest change of the
// control points that moves chosen points to chosen targets.
#include "deformkit/lattice/control_lattice.hpp"

#include <vector>

namespace deformkit {

struct DirectManipulationResult {
  std::vector<double> control_points;  // the new grid (the lattice itself is not modified)
  std::vector<double> displacement;    // new - old, per grid point
  std::vector<double> residual;        // |F'(p) - target| per constrained point
  int rank = 0;                        // rank of the constraint matrix
};

// Minimum-norm least-squares dP = B^+ dQ / strength over the lattice's handles (merged control
// points move together). Throws std::invalid_argument naming points or targets for bad input.
DirectManipulationResult direct_manipulation(const ControlLattice& lattice, const double* points,
                                             const double* targets, std::size_t m);

}  // namespace deformkit
