#include "deformkit/cage/green_cage.hpp"

#include "cage/green_coordinates.hpp"
#include "cage/green_rows.hpp"

#include <algorithm>
#include <cmath>

namespace deformkit {

GreenCage::GreenCage(CageMesh cage, bool stretch) : CageDeformer(std::move(cage)), stretch_(stretch) {
  for (const CageTriangle& t : this->cage().triangles()) triangles_.insert(triangles_.end(), t.begin(), t.end());
  tables_ = std::make_shared<const GreenCageTables>(green_cage_tables(view()));
}

TriangleCageView GreenCage::view() const {
  return {rest_cage_points().data(), vertex_count(), triangles_.data(), triangles_.size() / 3};
}

void GreenCage::coordinates(const Vec3& x, double* w, double* dw) const {
  const std::size_t m = vertex_count();
  const double p[3] = {x[0], x[1], x[2]};
  green_coordinates(p, view(), w, w + m, dw, dw == nullptr ? nullptr : dw + 3 * m, tables_.get());
}

void GreenCage::coordinate_rows(const double* points, std::size_t n, double* w) const {
  green_coordinate_rows(points, n, view(), *tables_, w);
}

void GreenCage::control_values(double* out) const {
  const std::vector<double>& current = cage_points();
  const std::size_t t = triangles_.size() / 3;
  std::copy(current.begin(), current.end(), out);
  std::vector<double> factors;
  if (stretch_) {  // s_j from the rest and deformed edges (docs/math/green_coordinates.md, "Stretch factor")
    factors.resize(t);
    green_stretch_factors(rest_cage_points().data(), current.data(), triangles_.data(), t, factors.data());
  }
  green_scaled_normals(current.data(), triangles_.data(), t, stretch_ ? factors.data() : nullptr,
                       out + current.size());
}

void GreenCage::vector_column_bounds(double* out) const {
  // Lipman's s_j = sqrt(|u'|^2 |v|^2 - 2 (u'.v')(u.v) + |v'|^2 |u|^2) / (sqrt(8) area) is at most
  // (|u'| |v| + |v'| |u|) / (sqrt(8) area) (Cauchy-Schwarz), and deformed edges are at most 2 R' long.
  const std::vector<double>& p = rest_cage_points();
  auto point = [&](int i) { return Vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]); };
  for (std::size_t j = 0; j < triangles_.size() / 3; ++j) {
    const int* v = triangles_.data() + 3 * j;
    const Vec3 u = point(v[1]) - point(v[0]), w = point(v[2]) - point(v[0]);
    out[j] = (u.norm() + w.norm()) / (std::sqrt(2.0) * 0.5 * u.cross(w).norm());
  }
}

}  // namespace deformkit
