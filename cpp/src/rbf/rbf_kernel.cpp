#include "deformkit/rbf/rbf_kernel.hpp"

#include <algorithm>
#include <cmath>

namespace deformkit {

const char* rbf_kernel_name(RbfKernel k) {
  switch (k) {
    case RbfKernel::ThinPlateSpline: return "thin_plate_spline";
    case RbfKernel::Cubic: return "cubic";
    case RbfKernel::Quintic: return "quintic";
    case RbfKernel::Linear: return "linear";
    case RbfKernel::Gaussian: return "gaussian";
    case RbfKernel::Multiquadric: return "multiquadric";
    case RbfKernel::InverseMultiquadric: return "inverse_multiquadric";
    case RbfKernel::InverseQuadratic: return "inverse_quadratic";
    case RbfKernel::WendlandC0: return "wendland_c0";
    case RbfKernel::WendlandC2: return "wendland_c2";
    case RbfKernel::WendlandC4: return "wendland_c4";
    case RbfKernel::Clip: return "clip";
  }
  return "?";
}

bool rbf_compact(RbfKernel kind) {
  return kind == RbfKernel::WendlandC0 || kind == RbfKernel::WendlandC2 || kind == RbfKernel::WendlandC4 ||
         kind == RbfKernel::Clip;
}

// The order of conditional positive definiteness minus one, as scipy's _NAME_TO_MIN_DEGREE
// (Wendland 2005, "Scattered Data Approximation", Thm. 8.16 for the powers, 8.17 for thin plate).
int rbf_minimum_degree(RbfKernel kind) {
  switch (kind) {
    case RbfKernel::ThinPlateSpline:
    case RbfKernel::Cubic:
      return 1;
    case RbfKernel::Quintic:
      return 2;
    case RbfKernel::Linear:
    case RbfKernel::Multiquadric:
      return 0;
    default:
      return -1;  // positive definite
  }
}

// Derivatives by hand from the definitions (docs/math/rbf.md, "Kernels"): slope = phi'(r) / r.
void rbf_kernel(const RbfKernelShape& k, double r, double* value, double* slope) {
  const double e = k.epsilon, s = e * r, s2 = s * s;
  const double rho = r / k.radius, t = std::max(0.0, 1.0 - rho), R2 = k.radius * k.radius;
  switch (k.kind) {
    case RbfKernel::ThinPlateSpline:
      *value = s > 0 ? s2 * std::log(s) : 0.0;
      *slope = s > 0 ? e * e * (2.0 * std::log(s) + 1.0) : 0.0;
      return;
    case RbfKernel::Cubic:
      *value = s2 * s;
      *slope = 3.0 * e * e * s;
      return;
    case RbfKernel::Quintic:
      *value = -s2 * s2 * s;
      *slope = -5.0 * e * e * s2 * s;
      return;
    case RbfKernel::Linear:
      *value = -s;
      *slope = r > 0 ? -e / r : 0.0;
      return;
    case RbfKernel::Gaussian:
      *value = std::exp(-s2);
      *slope = -2.0 * e * e * *value;
      return;
    case RbfKernel::Multiquadric:
      *value = -std::sqrt(1.0 + s2);
      *slope = e * e / *value;
      return;
    case RbfKernel::InverseMultiquadric: {
      const double q = 1.0 / std::sqrt(1.0 + s2);
      *value = q;
      *slope = -e * e * q * q * q;
      return;
    }
    case RbfKernel::InverseQuadratic: {
      const double q = 1.0 / (1.0 + s2);
      *value = q;
      *slope = -2.0 * e * e * q * q;
      return;
    }
    case RbfKernel::WendlandC0:
    case RbfKernel::Clip:
      *value = t * t;
      *slope = r > 0 ? -2.0 * t / (k.radius * r) : 0.0;
      return;
    case RbfKernel::WendlandC2: {
      const double t3 = t * t * t;
      *value = t3 * t * (4.0 * rho + 1.0);
      *slope = -20.0 * t3 / R2;
      return;
    }
    case RbfKernel::WendlandC4: {
      const double t5 = t * t * t * t * t;
      *value = t5 * t * (35.0 * rho * rho + 18.0 * rho + 3.0) / 3.0;  // scaled to phi(0) = 1
      *slope = -56.0 * t5 * (5.0 * rho + 1.0) / (3.0 * R2);
      return;
    }
  }
  *value = *slope = 0.0;
}

}  // namespace deformkit
