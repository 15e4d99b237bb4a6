#include "deformkit/lattice/direct_manipulation.hpp"

#include "lattice/handle_solve.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace deformkit {

HandleSolve solve_handles(const ControlLattice& lattice, const double* points, const double* targets, std::size_t m) {
  if (m == 0) throw std::invalid_argument("points: no points to move");
  require_finite_rows(points, m, "points");
  require_finite_rows(targets, m, "targets");
  if (lattice.strength() == 0.0)
    throw std::invalid_argument("strength: is 0, so no change of the control points can move the points");
  if (!lattice.weights().empty() && lattice.weights().size() != m)
    throw std::invalid_argument("weights: the lattice has " + std::to_string(lattice.weights().size()) +
                                " per-point weights but points has " + std::to_string(m) + " rows");
  const int handles = lattice.handle_count();
  // A dense complete orthogonal decomposition keeps rank-deficient and contradicting constraints
  // exact (normal equations would square the conditioning); it costs m h min(m, h) operations and
  // m h doubles, so both are bounded (about ten seconds and 400 MB here).
  const double h = handles, cost = double(m) * h * std::min(double(m), h);
  if (cost > 1e10 || double(m) * h > 5e7)
    throw std::invalid_argument("points: " + std::to_string(m) + " constraints on " + std::to_string(handles) +
                                " control points is too large for the dense least-squares solve; use fewer points "
                                "or a coarser lattice");
  const LatticeBinding binding = lattice.bind(points, m);
  const SparseWeights w = lattice.weights_matrix(binding);
  // Where deform() puts the points now, x + v strength W (P - R), with v the lattice's per-point
  // weights (the binding checked their count): a point of weight v moves v times as far, so its
  // constraint row is scaled by v, and a point of weight 0 cannot be moved at all.
  const auto& control = lattice.control_points();
  const auto& rest = lattice.rest_control_points();
  const std::vector<double>& point_weight = lattice.weights();
  auto weight_of = [&](std::size_t r) { return point_weight.empty() ? 1.0 : point_weight[r]; };
  std::vector<double> current(points, points + 3 * m);
  for (std::size_t r = 0; r < m; ++r)
    for (std::int64_t e = w.indptr[r]; e < w.indptr[r + 1]; ++e)
      for (int a = 0; a < 3; ++a)
        current[3 * r + a] += weight_of(r) * lattice.strength() * w.values[e] *
                              (control[3 * w.indices[e] + a] - rest[3 * w.indices[e] + a]);

  for (std::size_t i = 0; i < 3 * m; ++i)
    if (!std::isfinite(current[i]))
      throw std::invalid_argument("control_points: the lattice's current control points move point " +
                                  std::to_string(i / 3) + " beyond the double range");

  // B (m x h) over handles: merged control points add up in their handle.
  const auto& handle_of = lattice.handle_of();
  HandleSolve solve;
  Eigen::MatrixXd& dq = solve.dq;
  dq.resize(Eigen::Index(m), 3);
  for (std::size_t r = 0; r < m; ++r)
    for (int a = 0; a < 3; ++a) dq(Eigen::Index(r), a) = (targets[3 * r + a] - current[3 * r + a]) / lattice.strength();

  if (!dq.allFinite())  // the misses are finite (checked above): dividing by strength overflowed
  {
    std::ostringstream msg;
    msg << "strength: " << lattice.strength() << " is too small for these targets: the control-point change they "
           "need overflows a double";
    throw std::invalid_argument(msg.str());
  }

  // Minimum-norm least squares: B^+ dQ (B^T (B B^T)^-1 dQ at full row rank)
  // (docs/math/lattice.md, "Direct manipulation").
  Eigen::MatrixXd& b = solve.b;
  b = Eigen::MatrixXd::Zero(Eigen::Index(m), handles);
  for (std::size_t r = 0; r < m; ++r)
    for (std::int64_t e = w.indptr[r]; e < w.indptr[r + 1]; ++e)
      b(Eigen::Index(r), handle_of[w.indices[e]]) += weight_of(r) * w.values[e];
  solve.cod.compute(b);
  solve.dp = solve.cod.solve(dq);
  if (!solve.dp.allFinite())
    throw std::invalid_argument("targets: the control-point change needed overflows (targets too far from where "
                                "the current control_points put the points, or strength too small)");
  return solve;
}

DirectManipulationResult handle_result(const ControlLattice& lattice, const HandleSolve& solve,
                                       const Eigen::MatrixXd& dp) {
  const Eigen::MatrixXd reached = solve.b * dp;
  const Eigen::MatrixXd& dq = solve.dq;
  const std::size_t m = std::size_t(dq.rows());
  DirectManipulationResult result;
  result.rank = static_cast<int>(solve.cod.rank());
  result.residual.resize(m);
  // stableNorm: a miss of 1e200 per axis squares past the double range in norm().
  for (std::size_t r = 0; r < m; ++r) {
    result.residual[r] = std::abs(lattice.strength()) * (reached.row(Eigen::Index(r)) - dq.row(Eigen::Index(r))).stableNorm();
    if (!std::isfinite(result.residual[r]))
      throw std::invalid_argument("targets: point " + std::to_string(r) + " misses its target by more than a double "
                                  "holds (targets too far from the points)");
  }
  const auto& grid = lattice.control_points();
  result.control_points = grid;
  result.displacement.assign(grid.size(), 0.0);
  for (std::size_t g = 0; g < lattice.control_count(); ++g)
    for (int a = 0; a < 3; ++a) {
      result.displacement[3 * g + a] = dp(lattice.handle_of()[g], a);
      result.control_points[3 * g + a] += dp(lattice.handle_of()[g], a);
    }
  return result;
}

DirectManipulationResult direct_manipulation(const ControlLattice& lattice, const double* points,
                                             const double* targets, std::size_t m) {
  const HandleSolve solve = solve_handles(lattice, points, targets, m);
  return handle_result(lattice, solve, solve.dp);
}

}  // namespace deformkit
