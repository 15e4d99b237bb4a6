#pragma once
// Deformation transfer (Sumner and Popovic 2004): the per-triangle deformation gradients of a
// source mesh's pose, carried onto a target mesh, whose deformed positions are the least-squares
// fit of those gradients (the gradient form of Botsch, Sumner, Pauly, Gross 2006: no fourth-vertex
// unknowns). The target's system depends only on its rest shape: factorised once, each pose is one
// back-substitution, several poses one pass with more columns (docs/math/transfer.md).
// Same connectivity only for now: source and target share their faces (vertex i of one is vertex
// i of the other).
#include "deformkit/core/polygon_mesh.hpp"
#include "deformkit/numerics/constrained_quadratic.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace deformkit {

class DeformationTransfer {
 public:
  // source and target: the same faces (polygons are fanned into triangles from their first corner,
  // the same way for both) over their own rest points. Throws std::invalid_argument naming
  // target_points for another vertex count, source_faces / target_faces for a degenerate (zero
  // area) triangle, naming it.
  DeformationTransfer(const PolygonMesh& source, const std::vector<double>& target_points);

  std::size_t vertex_count() const { return source_.size() / 3; }
  std::size_t triangle_count() const { return triangles_.size() / 3; }
  // The vertices whose translation is fixed: the first of each connected part. Each moves by its
  // source partner's displacement, so that the rest pose transfers to the target rest exactly.
  const std::vector<int>& anchors() const { return anchors_; }

  // k poses of the source (k x n x 3, row-major) to k poses of the target (k x n x 3). Throws
  // std::invalid_argument naming source_pose for a non-finite value, or a pose that collapses a
  // triangle (no deformation gradient).
  void transfer(const double* poses, std::size_t k, double* out) const;

 private:
  std::vector<double> source_, target_;
  std::vector<int> triangles_;          // t x 3
  std::vector<Eigen::Matrix3d> frame_inverse_;  // per source triangle: V^-1 (Sumner and Popovic 2004, eq. 3)
  std::vector<Eigen::Matrix3d> tangent_;        // per target triangle: I - n n^T, times sqrt(area)
  std::vector<int> anchors_;
  ConstrainedQuadratic system_;
};

}  // namespace deformkit
