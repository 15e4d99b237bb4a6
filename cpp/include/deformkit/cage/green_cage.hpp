#pragma once
// Green coordinates of a closed cage (Lipman, Levin, Cohen-Or 2008; the extension: §3.3):
// F(x) = sum_i phi_i(x) v'_i + sum_j psi_j(x) s_j n(t'_j), with the exterior extension outside the
// cage (docs/math/green_coordinates.md).
#include "deformkit/cage/cage_deformer.hpp"

#include <memory>
#include <vector>

namespace deformkit {

struct GreenCageTables;  // the rest cage's point-independent terms (private: cpp/src/cage/green_rows.hpp)

class GreenCage : public CageDeformer {
 public:
  // stretch: Lipman's stretch factors s_j from the triangles' edges (similarities are reproduced,
  // the map is quasi-conformal); false: s_j = 1, for comparison.
  explicit GreenCage(CageMesh cage, bool stretch = true);
  bool stretch() const { return stretch_; }

  // A column per cage vertex (phi), then one per cage triangle (psi); the control values are the
  // current cage's vertices, then each triangle's s_j n(t'_j) (unit outward normal).
  std::size_t columns() const override { return vertex_count() + cage().triangles().size(); }
  void coordinates(const Vec3& x, double* w, double* dw) const override;
  void coordinate_rows(const double* points, std::size_t n, double* w) const override;
  void control_values(double* out) const override;
  // |s_j n'_j| <= kappa_j R' with kappa_j = (|u| + |v|) / (sqrt(2) area_j) from the rest edges u, v
  // (docs/math/cage.md, "Sparsified bindings"); with stretch = false |n'_j| = 1 <= kappa_j R / sqrt(2)
  // for R the rest cage's radius.
  std::size_t vertex_columns() const override { return vertex_count(); }
  void vector_column_bounds(double* out) const override;

 protected:
  // The coordinates do not depend on stretch: bindings are shared by both modes.
  const char* kind() const override { return "green"; }

 private:
  struct TriangleCageView view() const;  // the rest cage, as the private kernels take it

  std::vector<int> triangles_;  // t x 3, outward
  std::shared_ptr<const GreenCageTables> tables_;  // immutable: copies of the deformer share it
  bool stretch_;
};

}  // namespace deformkit
