#pragma once
// Direct manipulation of a lattice (Hsu, Hughes and Kaufman 1992): the smallest change of the
// control points that moves chosen points to chosen targets.
#include "deformkit/core/polygon_mesh.hpp"
#include "deformkit/lattice/control_lattice.hpp"

#include <vector>

namespace deformkit {

struct DirectManipulationResult {
  std::vector<double> control_points;  // the new grid (the lattice itself is not modified)
  std::vector<double> displacement;    // new - old, per grid point
  std::vector<double> residual;        // |F'(p) - target| per constrained point
  int rank = 0;                        // rank of the constraint matrix
  // With a volume to preserve: the closed mesh's signed volume under the new control points, the
  // one it had under the lattice's current ones, |volume - volume_target| / |volume_target|, and
  // the SQP iterations taken.
  bool preserves_volume = false;
  double volume = 0.0, volume_target = 0.0, volume_residual = 0.0;
  int iterations = 0;
};

// Minimum-norm least-squares dP = B^+ dQ / strength over the lattice's handles (merged control
// points move together). Throws std::invalid_argument naming points or targets for bad input.
DirectManipulationResult direct_manipulation(const ControlLattice& lattice, const double* points,
                                             const double* targets, std::size_t m);

// The same, keeping the signed volume of the closed mesh `preserve_volume`, deformed by the lattice
// (without per-point weights), at its volume under the current control points: the smallest
// change that meets the handle constraints as closely as the unconstrained solve does, by SQP
// (Hirota et al. 1999; docs/math/lattice.md, "Volume-preserving direct manipulation"). Throws
// std::invalid_argument naming preserve_volume for a mesh that is not closed and consistently
// oriented, of (near) zero volume, or when no volume-preserving change exists near.
DirectManipulationResult direct_manipulation(const ControlLattice& lattice, const double* points,
                                             const double* targets, std::size_t m,
                                             const PolygonMesh& preserve_volume);

}  // namespace deformkit
