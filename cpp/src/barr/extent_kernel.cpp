#include "barr/extent_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "barr/extent_kernel.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace deformkit {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

template <class T>
HWY_INLINE Extent ExtentOf(const double* row, double shift, const T* in, size_t n) {
  const hn::ScalableTag<T> d;
  using V = hn::Vec<decltype(d)>;
  const size_t N = hn::Lanes(d);
  const V r0 = hn::Set(d, T(row[0])), r1 = hn::Set(d, T(row[1])), r2 = hn::Set(d, T(row[2]));
  const V sh = hn::Set(d, T(shift));
  V lo = hn::Set(d, std::numeric_limits<T>::infinity()), hi = hn::Neg(lo), bad = hn::Zero(d);
  size_t i = 0;
  for (; i + N <= n; i += N) {
    V x, y, z;
    hn::LoadInterleaved3(d, in + 3 * i, x, y, z);
    bad = hn::MulAdd(hn::Zero(d), x, hn::MulAdd(hn::Zero(d), y, hn::MulAdd(hn::Zero(d), z, bad)));  // NaN iff not finite
    const V v = hn::MulAdd(r0, x, hn::MulAdd(r1, y, hn::MulSub(r2, z, sh)));
    lo = hn::Min(lo, v);
    hi = hn::Max(hi, v);
  }
  Extent e{double(hn::GetLane(hn::MinOfLanes(d, lo))), double(hn::GetLane(hn::MaxOfLanes(d, hi))),
           hn::AllTrue(d, hn::Eq(bad, bad))};
  for (; i < n; ++i) {
    const T v = T(row[0]) * in[3 * i] + T(row[1]) * in[3 * i + 1] + T(row[2]) * in[3 * i + 2] - T(shift);
    e.finite = e.finite && std::isfinite(in[3 * i]) && std::isfinite(in[3 * i + 1]) && std::isfinite(in[3 * i + 2]);
    e.lo = std::min(e.lo, double(v));
    e.hi = std::max(e.hi, double(v));
  }
  return e;
}

Extent ExtentF32(const double* row, double shift, const float* in, size_t n) { return ExtentOf(row, shift, in, n); }
Extent ExtentF64(const double* row, double shift, const double* in, size_t n) { return ExtentOf(row, shift, in, n); }

}  // namespace HWY_NAMESPACE
}  // namespace deformkit
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace deformkit {

HWY_EXPORT(ExtentF32);
HWY_EXPORT(ExtentF64);

Extent coordinate_extent(const double row[3], double shift, const float* points, std::size_t n) {
  return HWY_DYNAMIC_DISPATCH(ExtentF32)(row, shift, points, n);
}
Extent coordinate_extent(const double row[3], double shift, const double* points, std::size_t n) {
  return HWY_DYNAMIC_DISPATCH(ExtentF64)(row, shift, points, n);
}

}  // namespace deformkit
#endif  // HWY_ONCE
