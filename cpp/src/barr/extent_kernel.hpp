#pragma once
// Extent of one affine coordinate over a point set (SIMD, dispatched at run time): the bounding
// pass of Blender's Simple Deform, which runs on every evaluation.
#include <cstddef>

namespace deformkit {

struct Extent {
  double lo, hi;
  bool finite;  // false if some row was not finite (lo/hi are then unspecified)
};

// min and max of row . p - shift over the n rows p of an n x 3 array.
Extent coordinate_extent(const double row[3], double shift, const float* points, std::size_t n);
Extent coordinate_extent(const double row[3], double shift, const double* points, std::size_t n);

}  // namespace deformkit
