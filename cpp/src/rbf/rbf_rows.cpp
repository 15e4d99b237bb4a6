// Compiled once per x86 target by Highway and dispatched at run time: no -march needed.
// rbf_kernel() (rbf_kernel.cpp) is the reference for each phi; here phi is written in r^2, so
// that only the kernels that need r take a square root.
#include "rbf/rbf_rows.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "rbf/rbf_rows.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"
#include "hwy/contrib/math/math-inl.h"

HWY_BEFORE_NAMESPACE();
namespace deformkit {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using D = hn::ScalableTag<double>;
using V = hn::Vec<D>;

// exp(-u) for u >= 0, to a few ulps: -u = k ln 2 - t with |t| <= ln 2 / 2 (k rounded by the
// 1.5 * 2^52 shift), e^-t by its Taylor polynomial to degree 13 (the remainder below 5e-18), and
// 2^k added to the exponent bits. Above u = 707 (where 2^k would be subnormal) the result is 0:
// less than 1e-307, nothing a sum of kernel values can see. A general exp must also handle
// overflow and subnormal results: this costs a quarter less.
HWY_INLINE V ExpOfMinus(D d, V u) {
  const hn::RebindToSigned<D> di;
  const V shift = hn::Set(d, 6755399441055744.0);  // 1.5 * 2^52: adding it rounds to an integer
  const V shifted = hn::MulAdd(u, hn::Set(d, -1.4426950408889634074), shift);
  const V k = hn::Sub(shifted, shift);
  V t = hn::MulAdd(k, hn::Set(d, 6.93147180369123816490e-01), u);  // ln 2, high and low parts
  t = hn::MulAdd(k, hn::Set(d, 1.90821492927058770002e-10), t);
  V p = hn::Set(d, -1.0 / 6227020800.0);  // e^-t = sum_n (-t)^n / n!, from n = 13 down
  const double coefficients[] = {1.0 / 479001600.0, -1.0 / 39916800.0, 1.0 / 3628800.0, -1.0 / 362880.0,
                                 1.0 / 40320.0,     -1.0 / 5040.0,     1.0 / 720.0,     -1.0 / 120.0,
                                 1.0 / 24.0,        -1.0 / 6.0,        0.5,             -1.0,
                                 1.0};
  for (double c : coefficients) p = hn::MulAdd(p, t, hn::Set(d, c));
  const auto exponent = hn::ShiftLeft<52>(hn::BitCast(di, shifted));  // k in the low bits of shifted
  const V scaled = hn::BitCast(d, hn::Add(hn::BitCast(di, p), exponent));
  return hn::IfThenElseZero(hn::Le(u, hn::Set(d, 707.0)), scaled);
}

// phi as a function of s^2 = (epsilon r)^2: the points and controls come scaled by epsilon.
template <RbfKernel K>
HWY_INLINE V Phi(D d, V s2) {
  const V one = hn::Set(d, 1.0), zero = hn::Zero(d);
  if constexpr (K == RbfKernel::ThinPlateSpline) {  // s^2 log s = s^2 log(s^2) / 2, 0 at s = 0
    return hn::IfThenElse(hn::Gt(s2, zero), hn::Mul(hn::Mul(hn::Set(d, 0.5), s2), hn::Log(d, s2)), zero);
  } else if constexpr (K == RbfKernel::Cubic) {
    return hn::Mul(s2, hn::Sqrt(s2));
  } else if constexpr (K == RbfKernel::Quintic) {
    return hn::Neg(hn::Mul(hn::Mul(s2, s2), hn::Sqrt(s2)));
  } else if constexpr (K == RbfKernel::Linear) {
    return hn::Neg(hn::Sqrt(s2));
  } else if constexpr (K == RbfKernel::Gaussian) {
    return ExpOfMinus(d, s2);
  } else if constexpr (K == RbfKernel::Multiquadric) {
    return hn::Neg(hn::Sqrt(hn::Add(one, s2)));
  } else if constexpr (K == RbfKernel::InverseMultiquadric) {
    return hn::Div(one, hn::Sqrt(hn::Add(one, s2)));
  } else {
    static_assert(K == RbfKernel::InverseQuadratic, "the compact kernels go through the grid");
    return hn::Div(one, hn::Add(one, s2));
  }
}

template <RbfKernel K>
void Sums(const double* points, size_t n, const RbfColumns& col, const RbfKernelShape& shape, double* out) {
  const D d;
  const size_t N = hn::Lanes(d), m = col.m;
  const double e = shape.epsilon;
  // Points and controls scaled by epsilon once, so that |e x - e c|^2 is the kernels' s^2.
  thread_local std::vector<double> scaled;
  scaled.resize(3 * m);
  for (int a = 0; a < 3; ++a)
    for (size_t j = 0; j < m; ++j) scaled[a * m + j] = e * col.c[a][j];
  const double* c[3] = {scaled.data(), scaled.data() + m, scaled.data() + 2 * m};
  std::vector<double> lane(3 * N);
  for (size_t base = 0; base < n; base += N) {
    const size_t used = std::min(N, n - base);
    for (size_t k = 0; k < N; ++k)  // spare lanes repeat the last point
      for (int a = 0; a < 3; ++a) lane[a * N + k] = e * points[3 * (base + std::min(k, used - 1)) + a];
    const V x = hn::LoadU(d, lane.data()), y = hn::LoadU(d, lane.data() + N), z = hn::LoadU(d, lane.data() + 2 * N);
    V sx = hn::Zero(d), sy = hn::Zero(d), sz = hn::Zero(d);
    for (size_t j = 0; j < m; ++j) {
      const V dx = hn::Sub(x, hn::Set(d, c[0][j])), dy = hn::Sub(y, hn::Set(d, c[1][j])),
              dz = hn::Sub(z, hn::Set(d, c[2][j]));
      const V phi = Phi<K>(d, hn::MulAdd(dz, dz, hn::MulAdd(dy, dy, hn::Mul(dx, dx))));
      sx = hn::MulAdd(phi, hn::Set(d, col.alpha[0][j]), sx);
      sy = hn::MulAdd(phi, hn::Set(d, col.alpha[1][j]), sy);
      sz = hn::MulAdd(phi, hn::Set(d, col.alpha[2][j]), sz);
    }
    hn::StoreU(sx, d, lane.data());
    hn::StoreU(sy, d, lane.data() + N);
    hn::StoreU(sz, d, lane.data() + 2 * N);
    for (size_t k = 0; k < used; ++k)
      for (int a = 0; a < 3; ++a) out[3 * (base + k) + a] = lane[a * N + k];
  }
}

void KernelSums(const double* points, size_t n, const RbfColumns& col, const RbfKernelShape& shape, double* out) {
  switch (shape.kind) {
    case RbfKernel::ThinPlateSpline: return Sums<RbfKernel::ThinPlateSpline>(points, n, col, shape, out);
    case RbfKernel::Cubic: return Sums<RbfKernel::Cubic>(points, n, col, shape, out);
    case RbfKernel::Quintic: return Sums<RbfKernel::Quintic>(points, n, col, shape, out);
    case RbfKernel::Linear: return Sums<RbfKernel::Linear>(points, n, col, shape, out);
    case RbfKernel::Gaussian: return Sums<RbfKernel::Gaussian>(points, n, col, shape, out);
    case RbfKernel::Multiquadric: return Sums<RbfKernel::Multiquadric>(points, n, col, shape, out);
    case RbfKernel::InverseMultiquadric: return Sums<RbfKernel::InverseMultiquadric>(points, n, col, shape, out);
    case RbfKernel::InverseQuadratic: return Sums<RbfKernel::InverseQuadratic>(points, n, col, shape, out);
    default:  // a compact kernel, which the grid serves: the scalar definition, for completeness
      for (size_t i = 0; i < n; ++i) {
        double s[3] = {0, 0, 0};
        for (size_t j = 0; j < col.m; ++j) {
          const double dx = points[3 * i] - col.c[0][j], dy = points[3 * i + 1] - col.c[1][j],
                       dz = points[3 * i + 2] - col.c[2][j];
          double v, slope;
          rbf_kernel(shape, std::sqrt(dx * dx + dy * dy + dz * dz), &v, &slope);
          for (int a = 0; a < 3; ++a) s[a] += col.alpha[a][j] * v;
        }
        for (int a = 0; a < 3; ++a) out[3 * i + a] = s[a];
      }
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace deformkit
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace deformkit {

HWY_EXPORT(KernelSums);

void rbf_kernel_sums(const double* points, std::size_t n, const RbfColumns& columns, const RbfKernelShape& shape,
                     double* out) {
  HWY_DYNAMIC_DISPATCH(KernelSums)(points, n, columns, shape, out);
}

}  // namespace deformkit
#endif  // HWY_ONCE
