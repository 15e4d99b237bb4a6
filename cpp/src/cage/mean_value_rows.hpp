#pragma once
// Mean value coordinates of many points at once, SIMD lanes over points: MeanValueCage's
// determinant form evaluated for a vector of points per cage triangle (docs/math/cage.md,
// "Binding many points").
#include <cstddef>

namespace deformkit {

// The rest cage as the rows need it: points m x 3, outward triangles t x 3 with their unit normals
// (t x 3), and MeanValueCage's two closeness thresholds.
struct MeanValueCageView {
  const double* points = nullptr;
  std::size_t point_count = 0;
  const int* triangles = nullptr;
  const double* normals = nullptr;
  std::size_t triangle_count = 0;
  double on_cage = 0.0;     // absolute: this close to a vertex or a face's plane is on it
  double near_plane = 0.0;  // relative to the triangle's nearest vertex: gates the near-plane branch
};

// Rows of mean value coordinates (m per row) of n points (n x 3), normalised to sum to 1, equal to
// MeanValueCage's single-point weights to rounding. A point on a cage vertex or near a face's plane
// (the single-point code's guarded branches) is not computed: guarded[i] is set to 1 for it (else
// 0) and the caller computes its row. Not parallel: the caller splits the points between threads.
void mean_value_rows(const double* points, std::size_t n, const MeanValueCageView& cage, double* rows,
                     unsigned char* guarded);

}  // namespace deformkit
