#pragma once
// The signed volume of a closed mesh carried by a lattice, as a function of a handle change: the
// constraint of volume-preserving direct manipulation
// (docs/math/lattice.md, "Volume-preserving direct manipulation").
#include "deformkit/core/polygon_mesh.hpp"
#include "deformkit/lattice/control_lattice.hpp"

#include <Eigen/Dense>

#include <array>
#include <vector>

namespace deformkit {

// Throws std::invalid_argument "preserve_volume: mesh_faces: ..." unless every edge of the
// polygons is used exactly once in each direction: closed, manifold at edges, consistently oriented.
void require_closed_oriented(const PolygonMesh& mesh);

class LatticeMeshVolume {
 public:
  // Binds the mesh's points to the lattice (errors named preserve_volume: mesh_points) and
  // triangulates its faces. The mesh is checked by the caller.
  LatticeMeshVolume(const ControlLattice& lattice, const PolygonMesh& mesh);

  // V(dP) = 1/6 sum over triangles det(y_a, y_b, y_c), y = F(x) under control points P + dP
  // (dP per handle, h x 3); with `gradient`, dV/dP (h x 3) as well.
  double value(const Eigen::MatrixXd& dp, Eigen::MatrixXd* gradient = nullptr) const;
  // The Hessian of V at dP applied to a direction d (both h x 3): the derivative of the gradient
  // along d.
  Eigen::MatrixXd hessian_times(const Eigen::MatrixXd& dp, const Eigen::MatrixXd& d) const;
  // sum of |det| / 6 over the triangles at dP = 0: the scale the volume's rounding is relative to.
  double unsigned_sum() const { return unsigned_sum_; }

 private:
  std::vector<std::array<int, 3>> triangles_;
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> y0_;  // F(x) now, minus centre_
  std::vector<std::int64_t> indptr_;  // the lattice's weights, columns mapped to handles
  std::vector<int> handle_;
  std::vector<double> weight_;        // times strength
  int handles_ = 0;
  double unsigned_sum_ = 0.0;

  using Rows = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
  // offset + strength W dP per vertex, and strength W^T of per-vertex rows per handle.
  Rows carried(const Rows& offset, const Eigen::MatrixXd& dp) const;
  Eigen::MatrixXd pulled_back(const Rows& per_vertex) const;
};

}  // namespace deformkit
