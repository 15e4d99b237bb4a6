// Lane helpers that the families' derivative kernels share (Highway, once per target): from J in
// lanes to det(J) or the unit normal cof(J) n / |cof(J) n|, and which lanes the scalar,
// scale-free path must decide instead (docs/math/barr.md, "Derivatives in SIMD lanes").
// A kernel .cpp includes this after hwy/highway.h; the toggle guard lets foreach_target include it
// again for every target.
#if defined(DEFORMKIT_CORE_DERIVATIVE_LANES_INL_) == defined(HWY_TARGET_TOGGLE)
#ifdef DEFORMKIT_CORE_DERIVATIVE_LANES_INL_
#undef DEFORMKIT_CORE_DERIVATIVE_LANES_INL_
#else
#define DEFORMKIT_CORE_DERIVATIVE_LANES_INL_
#endif

#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace deformkit {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// The lanes of one vector step that the scalar path must take: an input or result not finite
// (0 v is NaN exactly then), or a magnitude below `tiny` (2^-900, float 2^-100), where the lanes'
// products could underflow and the scale-free arithmetic must decide.
template <class D>
class LaneTrouble {
 public:
  using T = hn::TFromD<D>;
  using V = hn::Vec<D>;
  explicit LaneTrouble(D d) : d_(d), bad_(hn::FirstN(d, 0)) {}
  void mark(V v) { bad_ = hn::Or(bad_, hn::Not(hn::Eq(hn::Mul(hn::Zero(d_), v), hn::Zero(d_)))); }
  void mark_small(V magnitude) {
    bad_ = hn::Or(bad_, hn::Not(hn::Ge(magnitude, hn::Set(d_, T(sizeof(T) == 4 ? 0x1p-100 : 0x1p-900)))));
  }
  // on_bad(l) for each marked lane l < lanes (the padding of a partial vector does not count);
  // true when there was none. Clears the marks for the next step.
  template <class F>
  bool report(std::size_t lanes, F&& on_bad) {
    const bool none = hn::AllFalse(d_, bad_);
    if (HWY_UNLIKELY(!none)) {
      HWY_ALIGN T lane_bad[HWY_MAX_BYTES / sizeof(T)] = {};
      hn::Store(hn::IfThenElseZero(bad_, hn::Set(d_, T(1))), d_, lane_bad);
      bool any = false;
      for (std::size_t l = 0; l < lanes; ++l)
        if (lane_bad[l] != T(0)) any = true, on_bad(l);
      bad_ = hn::FirstN(d_, 0);
      return !any;
    }
    return true;
  }

 private:
  D d_;
  hn::Mask<D> bad_;
};

// Rows of cof(J): the cross products J2 x J3, J3 x J1, J1 x J2 of J's columns (cofactor() in
// deformer.cpp); cof(J) = [c0 c1 c2] as columns.
template <class V>
HWY_INLINE void CofactorRows(const V j[3][3], V c[3][3]) {
  auto cross = [&](int a, int b, V* out) HWY_ATTR {
    out[0] = hn::MulSub(j[1][a], j[2][b], hn::Mul(j[2][a], j[1][b]));
    out[1] = hn::MulSub(j[2][a], j[0][b], hn::Mul(j[0][a], j[2][b]));
    out[2] = hn::MulSub(j[0][a], j[1][b], hn::Mul(j[1][a], j[0][b]));
  };
  cross(1, 2, c[0]);
  cross(2, 0, c[1]);
  cross(0, 1, c[2]);
}

template <class D, class V>
HWY_INLINE V DeterminantLanes(const V j[3][3], LaneTrouble<D>& trouble) {
  V c[3][3];
  CofactorRows(j, c);
  const V det = hn::MulAdd(j[0][0], c[0][0], hn::MulAdd(j[1][0], c[0][1], hn::Mul(j[2][0], c[0][2])));
  trouble.mark(det);
  trouble.mark_small(hn::Abs(det));
  return det;
}

// n (any length; made unit the scale-free way, divided by its largest component first) becomes
// the unit normal carried by J.
template <class D, class V>
HWY_INLINE void NormalLanes(const V j[3][3], V n[3], LaneTrouble<D>& trouble) {
  using T = hn::TFromD<D>;
  const D d;
  const V one = hn::Set(d, T(1));
  for (int a = 0; a < 3; ++a) trouble.mark(n[a]);
  const V big = hn::Max(hn::Abs(n[0]), hn::Max(hn::Abs(n[1]), hn::Abs(n[2])));
  trouble.mark_small(big);
  const V inv_big = hn::Div(one, big);
  for (int a = 0; a < 3; ++a) n[a] = hn::Mul(n[a], inv_big);
  const V inv_len = hn::Div(one, hn::Sqrt(hn::MulAdd(n[0], n[0], hn::MulAdd(n[1], n[1], hn::Mul(n[2], n[2])))));
  for (int a = 0; a < 3; ++a) n[a] = hn::Mul(n[a], inv_len);
  V c[3][3];
  CofactorRows(j, c);
  V o[3];
  for (int a = 0; a < 3; ++a) o[a] = hn::MulAdd(c[0][a], n[0], hn::MulAdd(c[1][a], n[1], hn::Mul(c[2][a], n[2])));
  // Each component: Max drops a NaN (x86's max returns its other operand), so inf - inf in one
  // component would pass a check of the largest alone and come out as a NaN normal.
  for (int a = 0; a < 3; ++a) trouble.mark(o[a]);
  const V top = hn::Max(hn::Abs(o[0]), hn::Max(hn::Abs(o[1]), hn::Abs(o[2])));
  trouble.mark(top);
  trouble.mark_small(top);
  const V inv_top = hn::Div(one, top);
  for (int a = 0; a < 3; ++a) o[a] = hn::Mul(o[a], inv_top);
  const V inv = hn::Div(one, hn::Sqrt(hn::MulAdd(o[0], o[0], hn::MulAdd(o[1], o[1], hn::Mul(o[2], o[2])))));
  for (int a = 0; a < 3; ++a) n[a] = hn::Mul(o[a], inv);
}

}  // namespace HWY_NAMESPACE
}  // namespace deformkit
HWY_AFTER_NAMESPACE();

#endif  // DEFORMKIT_CORE_DERIVATIVE_LANES_INL_
