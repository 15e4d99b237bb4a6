#pragma once
// Radial basis functions phi(r), named and scaled as scipy.interpolate.RBFInterpolator names them
// where it has them, plus the compactly supported Wendland functions (docs/math/rbf.md, "Kernels").
#include <cstdint>

namespace deformkit {

enum class RbfKernel : std::uint8_t {
  ThinPlateSpline,      // (eps r)^2 log(eps r)
  Cubic,                // (eps r)^3
  Quintic,              // -(eps r)^5
  Linear,               // -(eps r)
  Gaussian,             // exp(-(eps r)^2)
  Multiquadric,         // -sqrt(1 + (eps r)^2)
  InverseMultiquadric,  // 1 / sqrt(1 + (eps r)^2)
  InverseQuadratic,     // 1 / (1 + (eps r)^2)
  WendlandC0,           // (1 - r/R)_+^2
  WendlandC2,           // (1 - r/R)_+^4 (4 r/R + 1)
  WendlandC4,           // (1 - r/R)_+^6 (35 (r/R)^2 + 18 r/R + 3) / 3: phi(0) = 1 as the others
  Clip,                 // (clip(1 - r/R, 0, 1))^2: the RBF note's own kernel, equal to WendlandC0
};

struct RbfKernelShape {
  RbfKernel kind = RbfKernel::ThinPlateSpline;
  double epsilon = 1.0;  // the global kernels' shape parameter: phi(eps r)
  double radius = 1.0;   // the compact kernels' support R: phi = 0 for r >= R
};

// scipy's name of the kernel ('thin_plate_spline', ...; the compact ones 'wendland_c2', 'clip').
const char* rbf_kernel_name(RbfKernel kind);
// Compactly supported: zero at and beyond the radius.
bool rbf_compact(RbfKernel kind);
// Positive definite (any distinct points give a positive definite kernel matrix), or else
// conditionally positive definite of order rbf_minimum_degree() + 1.
// scipy's minimum polynomial degree: the system is well posed for degree >= this (-1: none needed).
int rbf_minimum_degree(RbfKernel kind);

// phi(r) into value and phi'(r) / r into slope (the gradient of phi(|x - c|) is slope (x - c)),
// for r >= 0. At r = 0, where phi'(r) / r has no limit for some kernels (linear, thin plate,
// Wendland C0), slope is 0: (x - c) = 0 there, and 0 is a subgradient.
void rbf_kernel(const RbfKernelShape& shape, double r, double* value, double* slope);

}  // namespace deformkit
