#pragma once
// The least-squares handle solve that direct manipulation and its volume-preserving variant share.
#include "deformkit/lattice/direct_manipulation.hpp"

#include <Eigen/Dense>

namespace deformkit {

// B dP = dQ over handles: B (m x h) the handles' weights (merged control points add up in their
// handle, rows scaled by the per-point weights), dQ (m x 3) the misses divided by strength.
struct HandleSolve {
  Eigen::MatrixXd b, dq;
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod;
  Eigen::MatrixXd dp;  // B^+ dQ (h x 3): the minimum-norm least-squares change

  // v - B^+ B v: the part of a change v (h x 3) that leaves every handle where it is.
  Eigen::MatrixXd free_part(const Eigen::MatrixXd& v) const { return v - cod.solve(b * v); }
};

// Checks points and targets and solves (throws std::invalid_argument naming points, targets,
// weights, strength or control_points as direct_manipulation documents).
HandleSolve solve_handles(const ControlLattice& lattice, const double* points, const double* targets, std::size_t m);

// The result of the handle change dp (h x 3): new grid, displacement, per-point residuals, rank.
DirectManipulationResult handle_result(const ControlLattice& lattice, const HandleSolve& solve,
                                       const Eigen::MatrixXd& dp);

}  // namespace deformkit
