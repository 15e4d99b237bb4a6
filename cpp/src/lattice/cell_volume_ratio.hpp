#pragma once
// What one call of the bounds needs of a lattice, read once: the control-point offsets and the
// constant d(s)/dx, so that each cell's Bezier extraction reads nothing else.
#include "deformkit/lattice/jacobian_bounds.hpp"

#include <vector>

namespace deformkit {

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
