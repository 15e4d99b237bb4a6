// Compiled once per x86 target by Highway and dispatched at run time: no -march needed.
#include "lattice/lattice_kernel.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "lattice/lattice_kernel.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace deformkit {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// The same weights as AxisBasis::evaluate, lane-wise.
template <class D, class V>
HWY_INLINE void AxisWeights(D d, const KernelAxis& a, V t, V* w) {
  using T = hn::TFromD<D>;
  const V one = hn::Set(d, T(1));
  const V u = hn::Sub(one, t);
  switch (a.basis) {
    case KernelBasis::Bernstein: {
      const int m = a.width - 1;
      V tp[16], up[16];
      tp[0] = up[0] = one;
      for (int i = 1; i <= m; ++i) {
        tp[i] = hn::Mul(tp[i - 1], t);
        up[i] = hn::Mul(up[i - 1], u);
      }
      double binom = 1.0;
      for (int i = 0; i <= m; ++i) {
        w[i] = hn::Mul(hn::Set(d, T(binom)), hn::Mul(tp[i], up[m - i]));
        binom = binom * (m - i) / (i + 1);
      }
      return;
    }
    case KernelBasis::CubicBSpline: {
      const V sixth = hn::Set(d, T(1.0 / 6.0)), t2 = hn::Mul(t, t), t3 = hn::Mul(t2, t);
      w[0] = hn::Mul(sixth, hn::Mul(u, hn::Mul(u, u)));
      w[3] = hn::Mul(sixth, t3);
      // N1 = (3t^3 - 6t^2 + 4)/6, N2 = 1 - N0 - N1 - N3 would lose precision near t = 1; use the polynomial.
      w[1] = hn::MulAdd(hn::Set(d, T(0.5)), t3, hn::MulAdd(hn::Set(d, T(-1)), t2, hn::Set(d, T(2.0 / 3.0))));
      w[2] = hn::MulAdd(hn::Set(d, T(-0.5)), t3,
                        hn::MulAdd(hn::Set(d, T(0.5)), t2, hn::MulAdd(hn::Set(d, T(0.5)), t, sixth)));
      return;
    }
    case KernelBasis::Linear:
      w[0] = u;
      w[1] = t;
      return;
    case KernelBasis::Cardinal: {
      const V fc = hn::Set(d, T(a.tension)), t2 = hn::Mul(t, t), t3 = hn::Mul(t2, t);
      const V two = hn::Set(d, T(2)), three = hn::Set(d, T(3));
      // key_curve_position_weights, KEY_CARDINAL / KEY_CATMULL_ROM.
      w[0] = hn::Mul(fc, hn::Sub(hn::Sub(hn::Mul(two, t2), t3), t));
      w[1] = hn::MulAdd(hn::Sub(two, fc), t3, hn::MulAdd(hn::Sub(fc, three), t2, one));
      w[2] = hn::MulAdd(hn::Sub(fc, two), t3, hn::MulAdd(hn::Sub(three, hn::Mul(two, fc)), t2, hn::Mul(fc, t)));
      w[3] = hn::Mul(fc, hn::Sub(t3, t2));
      return;
    }
    case KernelBasis::Constant:
      w[0] = one;
      return;
  }
}

template <int W0, int W1, int W2, class D, class V, class T>
HWY_INLINE void Contract(D d, const T* block, const V* w0, const V* w1, const V* w2, int n0, int n1, int n2, V& ax,
                         V& ay, V& az) {
  const int c0 = W0 ? W0 : n0, c1 = W1 ? W1 : n1, c2 = W2 ? W2 : n2;
  ax = ay = az = hn::Zero(d);
  for (int i = 0; i < c0; ++i)
    for (int j = 0; j < c1; ++j) {
      const T* b = block + 3 * ((i * c1 + j) * c2);
      V rx = hn::Zero(d), ry = hn::Zero(d), rz = hn::Zero(d);
      for (int k = 0; k < c2; ++k) {
        rx = hn::MulAdd(w2[k], hn::Set(d, b[3 * k]), rx);
        ry = hn::MulAdd(w2[k], hn::Set(d, b[3 * k + 1]), ry);
        rz = hn::MulAdd(w2[k], hn::Set(d, b[3 * k + 2]), rz);
      }
      const V wij = hn::Mul(w0[i], w1[j]);
      ax = hn::MulAdd(wij, rx, ax);
      ay = hn::MulAdd(wij, ry, ay);
      az = hn::MulAdd(wij, rz, az);
    }
}

template <class T>
bool CellKernel(const KernelAxis* axes, const T* block, const T* const* t, const T* const* base,
                const std::uint32_t* order, size_t count, T* out) {
  const hn::ScalableTag<T> d;
  using V = hn::Vec<decltype(d)>;
  const size_t N = hn::Lanes(d);
  const bool cubic = axes[0].width == 4 && axes[1].width == 4 && axes[2].width == 4;
  HWY_ALIGN T pad[3][HWY_MAX_BYTES / sizeof(T)], lane[3][HWY_MAX_BYTES / sizeof(T)];
  V bad = hn::Zero(d);  // 0 * v is NaN exactly when v is not finite: an overflow shows here
  for (size_t i = 0; i < count; i += N) {
    const size_t m = count - i < N ? count - i : N;
    V tv[3], bv[3];
    for (int a = 0; a < 3; ++a) {
      if (m == N) {
        tv[a] = hn::LoadU(d, t[a] + i);
        bv[a] = hn::LoadU(d, base[a] + i);
      } else {  // the tail: pad the lanes past the run with copies of a valid point
        for (size_t l = 0; l < N; ++l) pad[a][l] = t[a][i + (l < m ? l : 0)];
        tv[a] = hn::Load(d, pad[a]);
        for (size_t l = 0; l < N; ++l) pad[a][l] = base[a][i + (l < m ? l : 0)];
        bv[a] = hn::Load(d, pad[a]);
      }
    }
    V w0[16], w1[16], w2[16];
    AxisWeights(d, axes[0], tv[0], w0);
    AxisWeights(d, axes[1], tv[1], w1);
    AxisWeights(d, axes[2], tv[2], w2);
    V ax, ay, az;
    if (cubic) Contract<4, 4, 4>(d, block, w0, w1, w2, 4, 4, 4, ax, ay, az);
    else Contract<0, 0, 0>(d, block, w0, w1, w2, axes[0].width, axes[1].width, axes[2].width, ax, ay, az);
    const V ox = hn::Add(bv[0], ax), oy = hn::Add(bv[1], ay), oz = hn::Add(bv[2], az);
    bad = hn::MulAdd(hn::Zero(d), ox, hn::MulAdd(hn::Zero(d), oy, hn::MulAdd(hn::Zero(d), oz, bad)));
    hn::Store(ox, d, lane[0]);
    hn::Store(oy, d, lane[1]);
    hn::Store(oz, d, lane[2]);
    for (size_t l = 0; l < m; ++l) {
      T* o = out + 3 * size_t(order[i + l]);
      o[0] = lane[0][l], o[1] = lane[1][l], o[2] = lane[2][l];
    }
  }
  return hn::AllTrue(d, hn::Eq(bad, bad));  // Highway 1.0's Ne is ordered: NaN != NaN is false
}

bool CellF32(const KernelAxis* axes, const float* block, const float* const* t, const float* const* base,
             const std::uint32_t* order, size_t count, float* out) {
  return CellKernel(axes, block, t, base, order, count, out);
}
bool CellF64(const KernelAxis* axes, const double* block, const double* const* t, const double* const* base,
             const std::uint32_t* order, size_t count, double* out) {
  return CellKernel(axes, block, t, base, order, count, out);
}

}  // namespace HWY_NAMESPACE
}  // namespace deformkit
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace deformkit {

HWY_EXPORT(CellF32);
HWY_EXPORT(CellF64);

bool lattice_cell_kernel(const KernelAxis axes[3], const float* block, const float* const t[3],
                         const float* const base[3], const std::uint32_t* order, std::size_t count, float* out) {
  return HWY_DYNAMIC_DISPATCH(CellF32)(axes, block, t, base, order, count, out);
}
bool lattice_cell_kernel(const KernelAxis axes[3], const double* block, const double* const t[3],
                         const double* const base[3], const std::uint32_t* order, std::size_t count, double* out) {
  return HWY_DYNAMIC_DISPATCH(CellF64)(axes, block, t, base, order, count, out);
}

}  // namespace deformkit
#endif  // HWY_ONCE
