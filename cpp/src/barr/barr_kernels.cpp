// SIMD kernels for Barr operators with linear laws. Highway compiles this file once per
// x86 target (SSE2 ... AVX-512) and picks the best at run time: no -march needed.
#include "barr/barr_kernels.hpp"

#include <cmath>
#include <cstring>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "barr/barr_kernels.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"
#include "hwy/contrib/math/math-inl.h"

HWY_BEFORE_NAMESPACE();
namespace deformkit {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Highway's Sin/Cos are accurate to 3 ulp on [-39000, 39000]; beyond, use libm per lane.
template <class D, class V>
HWY_INLINE void SinCos(D d, V theta, V& s, V& c) {
  using T = hn::TFromD<D>;
  if (HWY_LIKELY(hn::AllFalse(d, hn::Gt(hn::Abs(theta), hn::Set(d, T(39000)))))) {
    s = hn::Sin(d, theta);
    c = hn::Cos(d, theta);
    return;
  }
  HWY_ALIGN T lanes[HWY_MAX_BYTES / sizeof(T)], sl[HWY_MAX_BYTES / sizeof(T)], cl[HWY_MAX_BYTES / sizeof(T)];
  hn::Store(theta, d, lanes);
  for (size_t i = 0; i < hn::Lanes(d); ++i) {
    sl[i] = std::sin(lanes[i]);
    cl[i] = std::cos(lanes[i]);
  }
  s = hn::Load(d, sl);
  c = hn::Load(d, cl);
}

template <int kKind, bool kIdentity, class T>
HWY_INLINE bool Run(const BarrKernelParams& p, const T* in, T* out, size_t n) {
  const hn::ScalableTag<T> d;
  using V = hn::Vec<decltype(d)>;
  const size_t N = hn::Lanes(d);
  auto set = [&](double v) { return hn::Set(d, static_cast<T>(v)); };
  const V M0 = set(p.M[0]), M1 = set(p.M[1]), M2 = set(p.M[2]), M3 = set(p.M[3]), M4 = set(p.M[4]),
          M5 = set(p.M[5]), M6 = set(p.M[6]), M7 = set(p.M[7]), M8 = set(p.M[8]);
  const V B0 = set(p.B[0]), B1 = set(p.B[1]), B2 = set(p.B[2]), B3 = set(p.B[3]), B4 = set(p.B[4]),
          B5 = set(p.B[5]), B6 = set(p.B[6]), B7 = set(p.B[7]), B8 = set(p.B[8]);
  const V m0 = set(p.m[0]), m1 = set(p.m[1]), m2 = set(p.m[2]);
  const V ux = set(p.unlocked[0]), uy = set(p.unlocked[1]);
  const V off = set(p.offset), off_minus_1 = set(p.offset - 1.0), slope = set(p.slope), lo = set(p.lo), hi = set(p.hi);
  const V k = set(p.k), center = set(p.center), half_k = set(0.5 * p.k), half = set(0.5), one = set(1.0),
          two = set(2.0), minus_two = set(-2.0);
  V bad = hn::Zero(d);

  // Each operator as its displacement in canonical coordinates (see barr_offset_with_jacobian),
  // exactly zero at rest, added to the object point through B: x' = x + B (g(c) - c).
  auto step = [&](const T* src, T* dst) HWY_ATTR {
    V px, py, pz;
    hn::LoadInterleaved3(d, src, px, py, pz);
    // 0 * v is NaN exactly when v is NaN or infinite (per coordinate: a sum could overflow).
    bad = hn::MulAdd(hn::Zero(d), px, hn::MulAdd(hn::Zero(d), py, hn::MulAdd(hn::Zero(d), pz, bad)));
    V x = px, y = py, z = pz;
    if (!kIdentity) {
      x = hn::MulAdd(M0, px, hn::MulAdd(M1, py, hn::MulAdd(M2, pz, m0)));
      y = hn::MulAdd(M3, px, hn::MulAdd(M4, py, hn::MulAdd(M5, pz, m1)));
      z = hn::MulAdd(M6, px, hn::MulAdd(M7, py, hn::MulAdd(M8, pz, m2)));
    }
    V dx, dy, dz;
    if (kKind == 3) {  // bend, half-angle form
      const V yc = hn::Min(hn::Max(y, lo), hi);
      V h, c2;
      SinCos(d, hn::Mul(half_k, hn::Sub(yc, center)), h, c2);
      const V s = hn::Mul(two, hn::Mul(h, c2));
      const V cm1 = hn::Mul(minus_two, hn::Mul(h, h));  // cos(t) - 1
      const V q2 = hn::Div(hn::Mul(two, h), k);  // 2 sin(t/2) / k
      const V dd = hn::Sub(y, yc);
      dx = hn::Zero(d);
      dy = hn::MulAdd(cm1, dd, hn::NegMulAdd(s, z, hn::MulSub(q2, c2, hn::Sub(yc, center))));
      dz = hn::MulAdd(cm1, z, hn::MulAdd(q2, h, hn::Mul(s, dd)));
    } else {
      const V zc = hn::Min(hn::Max(z, lo), hi);
      const V qx = hn::Mul(ux, x), qy = hn::Mul(uy, y);
      dz = hn::Zero(d);
      if (kKind == 0) {  // twist: cos(t) - 1 = -2 sin^2(t/2), exactly 0 at t = 0
        V h, c2;
        SinCos(d, hn::Mul(half, hn::MulAdd(slope, zc, off)), h, c2);
        const V s = hn::Mul(two, hn::Mul(h, c2));
        const V cm1 = hn::Mul(minus_two, hn::Mul(h, h));
        dx = hn::NegMulAdd(qy, s, hn::Mul(qx, cm1));
        dy = hn::MulAdd(qx, s, hn::Mul(qy, cm1));
      } else if (kKind == 1) {  // taper: r - 1
        const V rm1 = hn::MulAdd(slope, zc, off_minus_1);
        dx = hn::Mul(qx, rm1);
        dy = hn::Mul(qy, rm1);
      } else {  // stretch: s - 1 = k (z^2 - 1)
        const V sm1 = hn::Mul(k, hn::MulSub(zc, zc, one));
        dx = hn::Mul(qx, sm1);
        dy = hn::Mul(qy, sm1);
        dz = hn::Mul(k, zc);
      }
    }
    V ox, oy, oz;
    if (kIdentity) {
      ox = hn::Add(px, dx), oy = hn::Add(py, dy), oz = hn::Add(pz, dz);
    } else {
      ox = hn::Add(px, hn::MulAdd(B0, dx, hn::MulAdd(B1, dy, hn::Mul(B2, dz))));
      oy = hn::Add(py, hn::MulAdd(B3, dx, hn::MulAdd(B4, dy, hn::Mul(B5, dz))));
      oz = hn::Add(pz, hn::MulAdd(B6, dx, hn::MulAdd(B7, dy, hn::Mul(B8, dz))));
    }
    bad = hn::MulAdd(hn::Zero(d), ox, hn::MulAdd(hn::Zero(d), oy, hn::MulAdd(hn::Zero(d), oz, bad)));
    hn::StoreInterleaved3(ox, oy, oz, d, dst);
  };

  size_t i = 0;
  for (; i + N <= n; i += N) step(in + 3 * i, out + 3 * i);
  if (i < n) {  // the last partial vector goes through a zero-padded buffer
    HWY_ALIGN T buf[3 * HWY_MAX_BYTES / sizeof(T)] = {};
    std::memcpy(buf, in + 3 * i, 3 * (n - i) * sizeof(T));
    step(buf, buf);
    std::memcpy(out + 3 * i, buf, 3 * (n - i) * sizeof(T));
  }
  return hn::AllTrue(d, hn::Eq(bad, bad));  // ordered compare: false on NaN lanes
}

template <class T>
HWY_INLINE bool Dispatch(const BarrKernelParams& p, const T* in, T* out, size_t n) {
  const bool id = p.identity_placement;
  switch (p.kind) {
    case 0: return id ? Run<0, true>(p, in, out, n) : Run<0, false>(p, in, out, n);
    case 1: return id ? Run<1, true>(p, in, out, n) : Run<1, false>(p, in, out, n);
    case 2: return id ? Run<2, true>(p, in, out, n) : Run<2, false>(p, in, out, n);
    default: return id ? Run<3, true>(p, in, out, n) : Run<3, false>(p, in, out, n);
  }
}

bool KernelF32(const BarrKernelParams& p, const float* in, float* out, size_t n) {
  return Dispatch(p, in, out, n);
}
bool KernelF64(const BarrKernelParams& p, const double* in, double* out, size_t n) {
  return Dispatch(p, in, out, n);
}
const char* TargetName() { return hwy::TargetName(HWY_TARGET); }

}  // namespace HWY_NAMESPACE
}  // namespace deformkit
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace deformkit {

HWY_EXPORT(KernelF32);
HWY_EXPORT(KernelF64);
HWY_EXPORT(TargetName);

bool barr_kernel(const BarrKernelParams& p, const float* in, float* out, std::size_t n) {
  return HWY_DYNAMIC_DISPATCH(KernelF32)(p, in, out, n);
}
bool barr_kernel(const BarrKernelParams& p, const double* in, double* out, std::size_t n) {
  return HWY_DYNAMIC_DISPATCH(KernelF64)(p, in, out, n);
}
const char* simd_target() { return HWY_DYNAMIC_DISPATCH(TargetName)(); }

}  // namespace deformkit
#endif  // HWY_ONCE
