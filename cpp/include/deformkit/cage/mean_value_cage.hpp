#pragma once
// Mean value coordinates of a closed triangle cage (Ju, Schaefer, Warren 2005), in the
// determinant form of Thiery, Memari, Boubekeur 2018 (docs/math/cage.md, "Mean value coordinates").
#include "deformkit/cage/cage_deformer.hpp"

#include <vector>

namespace deformkit {

class MeanValueCage : public CageDeformer {
 public:
  explicit MeanValueCage(CageMesh cage);

  // One column per cage vertex; the control values are the current cage's vertices.
  std::size_t columns() const override { return vertex_count(); }
  // Exact on the cage (a vertex: that vertex's column 1; a face: the barycentric weights of its
  // triangle), defined outside it; dw (3 per column) are the exact gradients (dual numbers through
  // the same formula), zero at a cage vertex.
  void coordinates(const Vec3& x, double* w, double* dw) const override;
  void coordinate_rows(const double* points, std::size_t n, double* w) const override;
  void control_values(double* out) const override;

 protected:
  const char* kind() const override { return "mean value"; }

 private:
  template <class T>
  void weights(const T* x, T* w) const;

  std::vector<Vec3> normal_;   // unit outward normal per triangle
  std::vector<int> flat_triangles_;      // t x 3, and
  std::vector<double> flat_normals_;     // t x 3, for the SIMD rows
  std::vector<double> area2_;  // twice each triangle's area
  double on_cage_ = 0.0;       // a point this close to a vertex or face is on it
};

}  // namespace deformkit
