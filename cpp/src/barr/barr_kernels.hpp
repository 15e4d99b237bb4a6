#pragma once
// SIMD batch kernels for Barr operators with linear laws, dispatched at run time to the best
// instruction set of the CPU (Highway), so one binary runs on any x86-64.
#include <cstddef>

namespace deformkit {

struct BarrKernelParams {
  int kind;                 // BarrKind
  double M[9], m[3];        // object -> canonical
  double B[9];              // canonical -> object, linear part (the kernels add offsets)
  bool identity_placement;
  double unlocked[3];       // 1 for a free canonical axis, 0 for a locked one
  double offset, slope, lo, hi;  // linear law f = offset + slope * clamp(z, lo, hi) (twist/taper)
  double k, center;         // stretch factor / bend curvature, bend centre (lo/hi: region)
  bool displacement = false;  // write B (g(c) - c) = F(x) - x itself, not F(x) (checked as F(x) is)
};

// Processes rows [0, n); returns false if some input or output row was not finite.
bool barr_kernel(const BarrKernelParams& p, const float* in, float* out, std::size_t n);
bool barr_kernel(const BarrKernelParams& p, const double* in, double* out, std::size_t n);

// The derivative paths, rows [0, n): object-space Jacobians (9 per row, row-major), unit normals
// carried by cof(J) (Deformer's transform_normals), or det(J). weights: null, or one per row,
// blending J to I + w (J - I) as Deformer::jacobian does. They return false when some row needs
// the scalar path: an input or result not finite, a zero normal, or a magnitude so small (below
// 2^-900, float: 2^-100) that the scale-free scalar arithmetic must decide it; flags (one per
// row, or null) then mark those rows 1, leaving the others as they are (docs/math/barr.md,
// "Derivatives in SIMD lanes").
bool barr_jacobian_kernel(const BarrKernelParams& p, const double* weights, const double* in, double* jac, std::size_t n);
bool barr_normals_kernel(const BarrKernelParams& p, const double* weights, const double* in, const double* normals,
                         double* out, unsigned char* flags, std::size_t n);
bool barr_normals_kernel(const BarrKernelParams& p, const double* weights, const float* in, const float* normals,
                         float* out, unsigned char* flags, std::size_t n);
bool barr_determinant_kernel(const BarrKernelParams& p, const double* weights, const double* in, double* out,
                             unsigned char* flags, std::size_t n);

// Name of the instruction set the kernels dispatch to on this CPU (e.g. "AVX2").
const char* simd_target();

}  // namespace deformkit
