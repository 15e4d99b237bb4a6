// SIMD kernels for Barr operators with linear laws. Highway compiles this file once per
// x86 target (SSE2 ... AVX-512) and picks the best at run time: no -march needed.
#include "barr/barr_kernels.hpp"

#include <cmath>
#include <cstring>
#include <limits>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "barr/barr_kernels.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"
#include "hwy/contrib/math/math-inl.h"
#include "core/derivative_lanes-inl.hpp"

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

// kDisplacement is a template parameter, not a run-time branch in the loop: the branch cost the
// placed deform ~6% (register pressure), measured in an A/B at 1M points.
template <int kKind, bool kIdentity, bool kDisplacement, class T>
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
    if (kDisplacement) {  // the offset the sums above added, exact rather than F(x) - x rounded
      if (!kIdentity) {
        ox = hn::MulAdd(B0, dx, hn::MulAdd(B1, dy, hn::Mul(B2, dz)));
        oy = hn::MulAdd(B3, dx, hn::MulAdd(B4, dy, hn::Mul(B5, dz)));
        oz = hn::MulAdd(B6, dx, hn::MulAdd(B7, dy, hn::Mul(B8, dz)));
      } else {
        ox = dx, oy = dy, oz = dz;
      }
      bad = hn::MulAdd(hn::Zero(d), ox, hn::MulAdd(hn::Zero(d), oy, hn::MulAdd(hn::Zero(d), oz, bad)));
    }
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

template <bool kDisplacement, class T>
HWY_INLINE bool DispatchKind(const BarrKernelParams& p, const T* in, T* out, size_t n) {
  const bool id = p.identity_placement;
  switch (p.kind) {
    case 0: return id ? Run<0, true, kDisplacement>(p, in, out, n) : Run<0, false, kDisplacement>(p, in, out, n);
    case 1: return id ? Run<1, true, kDisplacement>(p, in, out, n) : Run<1, false, kDisplacement>(p, in, out, n);
    case 2: return id ? Run<2, true, kDisplacement>(p, in, out, n) : Run<2, false, kDisplacement>(p, in, out, n);
    default: return id ? Run<3, true, kDisplacement>(p, in, out, n) : Run<3, false, kDisplacement>(p, in, out, n);
  }
}

template <class T>
HWY_INLINE bool Dispatch(const BarrKernelParams& p, const T* in, T* out, size_t n) {
  return p.displacement ? DispatchKind<true>(p, in, out, n) : DispatchKind<false>(p, in, out, n);
}

// The canonical Jacobian's entries that differ from the identity, e[r][c] = Jc - I, per lane
// (barr_offset_with_jacobian's, term by term), for the derivative paths.
template <int kKind, class D, class V>
HWY_INLINE void CanonicalJacobianMinusI(D d, const BarrKernelParams& p, V x, V y, V z, V e[3][3]) {
  using T = hn::TFromD<D>;
  auto set = [&](double v) { return hn::Set(d, static_cast<T>(v)); };
  const V zero = hn::Zero(d), one = set(1.0), two = set(2.0), minus_two = set(-2.0), half = set(0.5);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) e[r][c] = zero;
  const V lo = set(p.lo), hi = set(p.hi);
  if (kKind == 3) {  // bend: [1 0 0; 0 C a -S; 0 S a C], a = 1 - k z inside the region
    const V yc = hn::Min(hn::Max(y, lo), hi);
    const auto inside = hn::And(hn::Ge(y, lo), hn::Le(y, hi));
    V h, c2;
    SinCos(d, hn::Mul(set(0.5 * p.k), hn::Sub(yc, set(p.center))), h, c2);
    const V s = hn::Mul(two, hn::Mul(h, c2));
    const V cm1 = hn::Mul(minus_two, hn::Mul(h, h));
    const V a = hn::IfThenElse(inside, hn::NegMulAdd(set(p.k), z, one), one);
    e[1][1] = hn::MulAdd(cm1, a, hn::Sub(a, one));  // C a - 1 = (C - 1) a + (a - 1)
    e[1][2] = hn::Neg(s);
    e[2][1] = hn::Mul(s, a);
    e[2][2] = cm1;
    return;
  }
  const V ux = set(p.unlocked[0]), uy = set(p.unlocked[1]);
  const V qx = hn::Mul(ux, x), qy = hn::Mul(uy, y);
  const V zc = hn::Min(hn::Max(z, lo), hi);
  const auto inside = hn::And(hn::Ge(z, lo), hn::Le(z, hi));
  if (kKind == 0) {  // twist
    V h, c2;
    SinCos(d, hn::Mul(half, hn::MulAdd(set(p.slope), zc, set(p.offset))), h, c2);
    const V s = hn::Mul(two, hn::Mul(h, c2));
    const V cm1 = hn::Mul(minus_two, hn::Mul(h, h));
    const V cs = hn::Add(one, cm1);
    const V dtheta = hn::IfThenElse(inside, set(p.slope), zero);
    e[0][0] = hn::Mul(ux, cm1);
    e[0][1] = hn::Neg(hn::Mul(uy, s));
    e[0][2] = hn::Mul(hn::Neg(hn::MulAdd(qx, s, hn::Mul(qy, cs))), dtheta);
    e[1][0] = hn::Mul(ux, s);
    e[1][1] = hn::Mul(uy, cm1);
    e[1][2] = hn::Mul(hn::MulSub(qx, cs, hn::Mul(qy, s)), dtheta);
  } else if (kKind == 1) {  // taper
    const V rm1 = hn::MulAdd(set(p.slope), zc, set(p.offset - 1.0));
    const V dr = hn::IfThenElse(inside, set(p.slope), zero);
    e[0][0] = hn::Mul(ux, rm1);
    e[0][2] = hn::Mul(qx, dr);
    e[1][1] = hn::Mul(uy, rm1);
    e[1][2] = hn::Mul(qy, dr);
  } else {  // stretch
    const V sm1 = hn::Mul(set(p.k), hn::MulSub(zc, zc, one));
    const V ds = hn::IfThenElse(inside, hn::Mul(set(2.0 * p.k), zc), zero);
    e[0][0] = hn::Mul(ux, sm1);
    e[0][2] = hn::Mul(qx, ds);
    e[1][1] = hn::Mul(uy, sm1);
    e[1][2] = hn::Mul(qy, ds);
    e[2][2] = hn::IfThenElse(inside, set(p.k), zero);
  }
}

// kWhat: 0 the Jacobian, 1 the carried normal, 2 det(J).
template <int kKind, bool kIdentity, int kWhat, class T>
HWY_INLINE bool RunDerivative(const BarrKernelParams& p, const double* weights, const T* in, const T* normals, T* out,
                              unsigned char* flags, size_t n) {
  const hn::ScalableTag<T> d;
  using V = hn::Vec<decltype(d)>;
  const size_t N = hn::Lanes(d);
  auto set = [&](double v) { return hn::Set(d, static_cast<T>(v)); };
  V M[9], B[9];
  for (int i = 0; i < 9; ++i) {
    M[i] = set(p.M[i]);
    B[i] = set(p.B[i]);
  }
  const V m0 = set(p.m[0]), m1 = set(p.m[1]), m2 = set(p.m[2]), one = set(1.0);
  bool all_good = true;

  auto step = [&](const T* src, const T* nsrc, const double* w, T* dst, unsigned char* flag, size_t lanes) HWY_ATTR {
    LaneTrouble<hn::ScalableTag<T>> trouble(d);
    auto finish = [&]() HWY_ATTR {
      if (!trouble.report(lanes, [&](size_t l) HWY_ATTR { if (flag) flag[l] = 1; })) all_good = false;
    };
    V px, py, pz;
    hn::LoadInterleaved3(d, src, px, py, pz);
    trouble.mark(px), trouble.mark(py), trouble.mark(pz);
    V x = px, y = py, z = pz;
    if (!kIdentity) {
      x = hn::MulAdd(M[0], px, hn::MulAdd(M[1], py, hn::MulAdd(M[2], pz, m0)));
      y = hn::MulAdd(M[3], px, hn::MulAdd(M[4], py, hn::MulAdd(M[5], pz, m1)));
      z = hn::MulAdd(M[6], px, hn::MulAdd(M[7], py, hn::MulAdd(M[8], pz, m2)));
    }
    V e[3][3];
    CanonicalJacobianMinusI<kKind>(d, p, x, y, z, e);
    // Object space: J - I = B (Jc - I) M (the identity exactly at rest), times the weight.
    V j[3][3];
    if (kIdentity) {
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) j[r][c] = e[r][c];
    } else {
      V be[3][3];
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
          be[r][c] = hn::MulAdd(B[3 * r], e[0][c], hn::MulAdd(B[3 * r + 1], e[1][c], hn::Mul(B[3 * r + 2], e[2][c])));
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
          j[r][c] = hn::MulAdd(be[r][0], M[c], hn::MulAdd(be[r][1], M[3 + c], hn::Mul(be[r][2], M[6 + c])));
    }
    if (w) {
      HWY_ALIGN T wl[HWY_MAX_BYTES / sizeof(T)] = {};
      for (size_t i = 0; i < lanes; ++i) wl[i] = static_cast<T>(w[i]);
      const V wv = hn::Load(d, wl);
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) j[r][c] = hn::Mul(wv, j[r][c]);
    }
    for (int r = 0; r < 3; ++r) j[r][r] = hn::Add(j[r][r], one);
    if (kWhat == 0) {
      HWY_ALIGN T lanes_out[9][HWY_MAX_BYTES / sizeof(T)];
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
          trouble.mark(j[r][c]);
          hn::Store(j[r][c], d, lanes_out[3 * r + c]);
        }
      for (size_t i = 0; i < lanes; ++i)
        for (int k = 0; k < 9; ++k) dst[9 * i + size_t(k)] = lanes_out[k][i];
      return finish();
    }
    if (kWhat == 2) {
      HWY_ALIGN T lane_det[HWY_MAX_BYTES / sizeof(T)];
      hn::Store(DeterminantLanes(j, trouble), d, lane_det);
      std::memcpy(dst, lane_det, lanes * sizeof(T));
      return finish();
    }
    V nv[3];
    hn::LoadInterleaved3(d, nsrc, nv[0], nv[1], nv[2]);
    NormalLanes(j, nv, trouble);
    hn::StoreInterleaved3(nv[0], nv[1], nv[2], d, dst);
    finish();
  };

  const size_t width = kWhat == 0 ? 9 : kWhat == 1 ? 3 : 1;
  size_t i = 0;
  for (; i + N <= n; i += N)
    step(in + 3 * i, normals ? normals + 3 * i : nullptr, weights ? weights + i : nullptr, out + width * i,
         flags ? flags + i : nullptr, N);
  if (i < n) {  // the last partial vector through zero-padded buffers (padding: unit normals at the origin)
    HWY_ALIGN T buf[3 * HWY_MAX_BYTES / sizeof(T)] = {}, nbuf[3 * HWY_MAX_BYTES / sizeof(T)] = {},
                obuf[9 * HWY_MAX_BYTES / sizeof(T)] = {};
    std::memcpy(buf, in + 3 * i, 3 * (n - i) * sizeof(T));
    for (size_t k = 0; k < N; ++k) nbuf[3 * k] = T(1);
    if (normals) std::memcpy(nbuf, normals + 3 * i, 3 * (n - i) * sizeof(T));
    HWY_ALIGN double wbuf[HWY_MAX_BYTES / sizeof(T)] = {};
    for (size_t k = 0; k < N; ++k) wbuf[k] = 1.0;
    if (weights) std::memcpy(wbuf, weights + i, (n - i) * sizeof(double));
    step(buf, nbuf, weights ? wbuf : nullptr, obuf, flags ? flags + i : nullptr, n - i);
    std::memcpy(out + width * i, obuf, width * (n - i) * sizeof(T));
  }
  return all_good;
}

template <int kWhat, class T>
HWY_INLINE bool DispatchDerivative(const BarrKernelParams& p, const double* w, const T* in, const T* nrm, T* out,
                                   unsigned char* f, size_t n) {
  const bool id = p.identity_placement;
  switch (p.kind) {
    case 0: return id ? RunDerivative<0, true, kWhat>(p, w, in, nrm, out, f, n) : RunDerivative<0, false, kWhat>(p, w, in, nrm, out, f, n);
    case 1: return id ? RunDerivative<1, true, kWhat>(p, w, in, nrm, out, f, n) : RunDerivative<1, false, kWhat>(p, w, in, nrm, out, f, n);
    case 2: return id ? RunDerivative<2, true, kWhat>(p, w, in, nrm, out, f, n) : RunDerivative<2, false, kWhat>(p, w, in, nrm, out, f, n);
    default: return id ? RunDerivative<3, true, kWhat>(p, w, in, nrm, out, f, n) : RunDerivative<3, false, kWhat>(p, w, in, nrm, out, f, n);
  }
}

bool JacobianF64(const BarrKernelParams& p, const double* w, const double* in, double* jac, size_t n) {
  return DispatchDerivative<0>(p, w, in, static_cast<const double*>(nullptr), jac, nullptr, n);
}
bool NormalsF64(const BarrKernelParams& p, const double* w, const double* in, const double* nrm, double* out,
                unsigned char* flags, size_t n) {
  return DispatchDerivative<1>(p, w, in, nrm, out, flags, n);
}
bool NormalsF32(const BarrKernelParams& p, const double* w, const float* in, const float* nrm, float* out,
                unsigned char* flags, size_t n) {
  return DispatchDerivative<1>(p, w, in, nrm, out, flags, n);
}
bool DeterminantF64(const BarrKernelParams& p, const double* w, const double* in, double* out, unsigned char* flags,
                    size_t n) {
  return DispatchDerivative<2>(p, w, in, static_cast<const double*>(nullptr), out, flags, n);
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
HWY_EXPORT(JacobianF64);
HWY_EXPORT(NormalsF64);
HWY_EXPORT(NormalsF32);
HWY_EXPORT(DeterminantF64);

bool barr_kernel(const BarrKernelParams& p, const float* in, float* out, std::size_t n) {
  return HWY_DYNAMIC_DISPATCH(KernelF32)(p, in, out, n);
}
bool barr_kernel(const BarrKernelParams& p, const double* in, double* out, std::size_t n) {
  return HWY_DYNAMIC_DISPATCH(KernelF64)(p, in, out, n);
}
const char* simd_target() { return HWY_DYNAMIC_DISPATCH(TargetName)(); }

bool barr_jacobian_kernel(const BarrKernelParams& p, const double* w, const double* in, double* jac, std::size_t n) {
  return HWY_DYNAMIC_DISPATCH(JacobianF64)(p, w, in, jac, n);
}
bool barr_normals_kernel(const BarrKernelParams& p, const double* w, const double* in, const double* normals, double* out,
                         unsigned char* flags, std::size_t n) {
  return HWY_DYNAMIC_DISPATCH(NormalsF64)(p, w, in, normals, out, flags, n);
}
bool barr_normals_kernel(const BarrKernelParams& p, const double* w, const float* in, const float* normals, float* out,
                         unsigned char* flags, std::size_t n) {
  return HWY_DYNAMIC_DISPATCH(NormalsF32)(p, w, in, normals, out, flags, n);
}
bool barr_determinant_kernel(const BarrKernelParams& p, const double* w, const double* in, double* out,
                             unsigned char* flags, std::size_t n) {
  return HWY_DYNAMIC_DISPATCH(DeterminantF64)(p, w, in, out, flags, n);
}

}  // namespace deformkit
#endif  // HWY_ONCE
