#pragma once
// What one call of the bounds needs of a lattice, read once: the control-point offsets and the
// constant d(s)/dx, so that each cell's Bezier extraction reads nothing else.
#include "deformkit/lattice/jacobian_bounds.hpp"

#include <vector>

namespace deformkit {

// One axis over one cell: the control points it touches and the Bernstein coefficients, over
// the cell's [lo, hi], of the weight of each: b[q * width + w].
struct AxisForm {
  int degree = 0;
  int width = 0;
  bool identity = false;  // the weights are the Bernstein polynomials themselves: the net is the offsets
  // Not zero-initialised: 2 kB per axis and cell would cost more than a trilinear cell's det.
  int index[kMaxAxisWidth];
  double b[kMaxAxisWidth * kMaxAxisWidth];
};

// The weights of `axis` over cell's piece and [lo, hi] along axis a (a frozen axis: degree 0, the
// weights at its t), exact: the identity for Bernstein and Bezier bases, a cubic's Bezier points
// from its Hermite data at the ends, weights vanishing over the cell dropped.
AxisForm axis_form(const AxisBasis& axis, const CellSpec& cell, int a);

struct LatticeView {
  const BoxLattice* lattice = nullptr;
  std::vector<double> offset;  // strength * (P - R), flattened as the control points
  Mat3 to_box = Mat3::Identity();
  bool at_rest = true;         // offset all zero: det J = 1 exactly
  explicit LatticeView(const BoxLattice& l);
};

CellVolumeRatio cell_volume_ratio(const LatticeView& view, const CellSpec& cell);

// Rest volume of a region cell: |det edges| times the cell's extent in s per axis.
double cell_rest_volume(const BoxLattice& lattice, const CellSpec& cell);

}  // namespace deformkit
