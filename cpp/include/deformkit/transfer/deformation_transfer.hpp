#pragma once
// Deformation transfer (Sumner and Popovic 2004): the per-triangle deformation gradients of a
// source mesh's pose, carried onto a target mesh, whose deformed positions are the least-squares
// fit of those gradients (the gradient form of Botsch, Sumner, Pauly, Gross 2006: no fourth-vertex
// unknowns). The target's system depends only on its rest shape and the triangle pairs: factorised
// once, each pose is one back-substitution, several poses one pass with more columns
// (docs/math/transfer.md).
#include "deformkit/core/polygon_mesh.hpp"
#include "deformkit/numerics/constrained_quadratic.hpp"
#include "deformkit/transfer/triangle_correspondence.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace deformkit {

// What ties the target to the source beyond the triangle pairs.
struct TransferPairing {
  // m x 2: (source triangle, target triangle); a target triangle in several pairs fits their mean
  // gradient, one in none keeps its rest shape (Sumner and Popovic 2004, eq. 5, identity rows).
  std::vector<int> pairs;
  // Target vertices whose positions each transfer is given (the paper's foot placement).
  std::vector<int> fixed_vertices;
  // (source vertex, target vertex) pairs fixing each target part's translation, which gradients
  // cannot: the mean of the part's listed target vertices moves by the mean displacement of their
  // source partners. A part with fixed vertices needs none; a part with none listed uses the
  // corners of its paired triangles (their centroids move as their partners' do).
  std::vector<int> reference;
};

class DeformationTransfer {
 public:
  // Same connectivity: source and target share their faces (vertex i of one is vertex i of the
  // other, polygons fanned alike); triangle j pairs with triangle j, and each connected part's
  // first vertex moves by its source partner's displacement, so that the rest pose transfers to
  // the target rest exactly. Throws std::invalid_argument naming target_points for another vertex
  // count, source_faces / target_faces for a triangle of zero area or a sliver (area under
  // kThinnestTriangle of its longest edge squared), naming it; so do the other constructors.
  DeformationTransfer(const PolygonMesh& source, const std::vector<double>& target_points,
                      const std::vector<int>& fixed_vertices = {});
  // Any two meshes, triangles numbered as triangulate() fans them. Throws std::invalid_argument
  // naming correspondence for a pair out of range, fixed_vertices for an index out of range or
  // repeated, and markers for a target part with no reference vertex, fixed vertex or pair.
  DeformationTransfer(const PolygonMesh& source, const PolygonMesh& target, const TransferPairing& pairing);
  // Unlike meshes from markers: the correspondence phase (triangle_correspondence), its pairs, and
  // the markers fixing each part's translation (their centroid moves as the source markers' does).
  DeformationTransfer(const PolygonMesh& source, const PolygonMesh& target, const std::vector<int>& source_markers,
                      const std::vector<int>& target_markers, const std::vector<int>& fixed_vertices = {},
                      const CorrespondenceOptions& options = {});

  std::size_t vertex_count() const { return source_.size() / 3; }  // the source's
  std::size_t target_vertex_count() const { return target_.size() / 3; }
  std::size_t triangle_count() const { return source_triangles_.size() / 3; }  // the source's
  std::size_t target_triangle_count() const { return target_triangles_.size() / 3; }
  const std::vector<int>& pairs() const { return pairs_; }
  // The triangles pairs() indexes (t x 3): each mesh's faces fanned from their first corner.
  const std::vector<int>& source_triangles() const { return source_triangles_; }
  const std::vector<int>& target_triangles() const { return target_triangles_; }
  const std::vector<int>& fixed_vertices() const { return fixed_vertices_; }
  // Target vertices held while solving, one per part without fixed vertices (its first); the
  // part is then moved by its reference translation.
  const std::vector<int>& anchors() const { return anchors_; }
  // Target triangles without a source partner.
  std::vector<int> unmatched_target_triangles() const;
  // The correspondence phase's result when built from markers (its pairs are pairs()), else null.
  const TriangleCorrespondence* correspondence_fit() const { return fitted_ ? &fit_ : nullptr; }

  // k poses of the source (k x n_s x 3, row-major) to k poses of the target (k x n_t x 3);
  // fixed_positions: k x f x 3 for the f fixed vertices, or null for their rest positions. Throws
  // std::invalid_argument naming source_pose for a non-finite value or a pose that collapses a
  // triangle (no deformation gradient), fixed_positions for a non-finite value.
  void transfer(const double* poses, std::size_t k, double* out, const double* fixed_positions = nullptr) const;

 private:
  void build(const PolygonMesh& source_triangles, const PolygonMesh& target_triangles, const TransferPairing& pairing);
  void transfer_block(const double* poses, std::size_t k, double* out, const double* fixed_positions) const;

  std::vector<double> source_, target_;
  std::vector<int> source_triangles_, target_triangles_;  // t x 3 each
  std::vector<int> pairs_;
  // Per source triangle: its rest frame V and V^-1 (Sumner and Popovic 2004, eq. 3).
  std::vector<Eigen::Matrix3d> frame_, frame_inverse_;
  // Per target triangle: its partners (CSR) and I - n n^T times sqrt(area / partners), which
  // turns the partners' summed gradients into the weighted mean's rows.
  std::vector<int> partner_offset_, partner_;
  std::vector<Eigen::Matrix3d> tangent_;
  std::vector<int> fixed_vertices_, anchors_;
  std::vector<int> part_;  // target vertex -> connected part
  // Per part without fixed vertices: its reference pairs (CSR into reference_ as source, target).
  std::vector<int> part_reference_offset_, reference_;
  std::vector<char> part_fixed_;
  ConstrainedQuadratic system_;
  TriangleCorrespondence fit_;
  bool fitted_ = false;
};

}  // namespace deformkit
