#pragma once
// Where points fall in a box lattice, in SIMD lanes (Highway, run-time dispatch): the parameters
// to_parameters (x - origin), each axis located as AxisBasis::locate does, the status and the
// cell key, bit for bit what the per-point formulas give (the file is compiled without
// floating-point contraction for that), without their branches.
#include <cstddef>
#include <cstdint>

namespace deformkit {

struct PlacementAxis {
  bool blender = false;  // Blender's index clamping (is_blender)
  int count = 2, pieces = 1;
  double lo = 0, hi = 1, scale = 1;  // AxisBasis's domain and d(t)/ds
};

struct Placement3 {
  double to_parameters[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  double origin[3] = {0, 0, 0};
  PlacementAxis axes[3];
  int outside = 0;            // Outside: 0 clamp, 1 unchanged, 2 extrapolate
  std::uint64_t still = 0;    // the key of points left where they are
};

// Rows [0, n) of in (x, y, z per row): parameters (3 per row), status (PointStatus, or null), key,
// local (3 per row: the coordinate within the cell) and ds (3 per row, or null: d(local)/ds, 0 on
// a clamped axis). Returns false when some row's parameters are not finite (the caller decides
// what that row is); the other rows are complete.
bool place_in_box(const Placement3& p, const double* in, std::size_t n, double* parameters, std::uint8_t* status,
                  std::uint64_t* key, double* local, double* ds);
bool place_in_box(const Placement3& p, const float* in, std::size_t n, double* parameters, std::uint8_t* status,
                  std::uint64_t* key, double* local, double* ds);

}  // namespace deformkit
