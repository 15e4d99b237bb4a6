// Compiled once per x86 target by Highway and dispatched at run time: no -march needed.
#include "lattice/lattice_kernel.hpp"

#include <stdexcept>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "lattice/lattice_kernel.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"
#include "core/derivative_lanes-inl.hpp"

HWY_BEFORE_NAMESPACE();
namespace deformkit {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// The same weights as AxisBasis::evaluate, lane-wise, and with dw their d/dt (not yet scaled to
// d/ds: the caller's ds does that, 0 on a clamped axis).
template <class D, class V>
HWY_INLINE void AxisWeights(D d, const KernelAxis& a, V t, V* w, V* dw = nullptr) {
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
      if (dw) {  // dB_i^m = m (B_{i-1}^{m-1} - B_i^{m-1}) (Sederberg-Parry 1986; docs/math/lattice.md)
        V lower[16];
        double c = 1.0;
        for (int i = 0; i < m; ++i) {
          lower[i] = hn::Mul(hn::Set(d, T(m * c)), hn::Mul(tp[i], up[m - 1 - i]));
          c = c * (m - 1 - i) / (i + 1);
        }
        for (int i = 0; i <= m; ++i)
          dw[i] = i == 0 ? hn::Neg(lower[0]) : i == m ? lower[m - 1] : hn::Sub(lower[i - 1], lower[i]);
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
      if (dw) {
        const V half = hn::Set(d, T(0.5)), three_halves = hn::Set(d, T(1.5));
        dw[0] = hn::Neg(hn::Mul(half, hn::Mul(u, u)));
        dw[1] = hn::MulSub(three_halves, t2, hn::Add(t, t));
        dw[2] = hn::Add(hn::NegMulAdd(three_halves, t2, t), half);
        dw[3] = hn::Mul(half, t2);
      }
      return;
    }
    case KernelBasis::Linear:
      w[0] = u;
      w[1] = t;
      if (dw) dw[0] = hn::Neg(one), dw[1] = one;
      return;
    case KernelBasis::Cardinal: {
      const V fc = hn::Set(d, T(a.tension)), t2 = hn::Mul(t, t), t3 = hn::Mul(t2, t);
      const V two = hn::Set(d, T(2)), three = hn::Set(d, T(3));
      // key_curve_position_weights, KEY_CARDINAL / KEY_CATMULL_ROM.
      w[0] = hn::Mul(fc, hn::Sub(hn::Sub(hn::Mul(two, t2), t3), t));
      w[1] = hn::MulAdd(hn::Sub(two, fc), t3, hn::MulAdd(hn::Sub(fc, three), t2, one));
      w[2] = hn::MulAdd(hn::Sub(fc, two), t3, hn::MulAdd(hn::Sub(three, hn::Mul(two, fc)), t2, hn::Mul(fc, t)));
      w[3] = hn::Mul(fc, hn::Sub(t3, t2));
      if (dw) {
        const V four = hn::Set(d, T(4));
        dw[0] = hn::Mul(fc, hn::Sub(hn::NegMulAdd(three, t2, hn::Mul(four, t)), one));
        dw[1] = hn::MulAdd(hn::Mul(three, hn::Sub(two, fc)), t2, hn::Mul(hn::Mul(two, hn::Sub(fc, three)), t));
        dw[2] = hn::MulAdd(hn::Mul(three, hn::Sub(fc, two)), t2,
                           hn::MulAdd(hn::Mul(two, hn::Sub(three, hn::Mul(two, fc))), t, fc));
        dw[3] = hn::Mul(fc, hn::MulSub(three, t2, hn::Add(t, t)));
      }
      return;
    }
    case KernelBasis::Constant:
      w[0] = one;
      if (dw) dw[0] = hn::Zero(d);
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
                const std::uint32_t* order, size_t count, T* out, const double* weights) {
  const hn::ScalableTag<T> d;
  using V = hn::Vec<decltype(d)>;
  const size_t N = hn::Lanes(d);
  const bool cubic = axes[0].width == 4 && axes[1].width == 4 && axes[2].width == 4;
  HWY_ALIGN T pad[3][HWY_MAX_BYTES / sizeof(T)], lane[3][HWY_MAX_BYTES / sizeof(T)];
  V bad = hn::Zero(d);  // 0 * v is NaN exactly when v is not finite: an overflow shows here
  for (size_t i = 0; i < count; i += N) {
    const size_t m = count - i < N ? count - i : N;
    V tv[3], bv[3] = {hn::Zero(d), hn::Zero(d), hn::Zero(d)};  // no base: the displacement alone
    for (int a = 0; a < 3; ++a) {
      if (m == N) {
        tv[a] = hn::LoadU(d, t[a] + i);
        if (base) bv[a] = hn::LoadU(d, base[a] + i);
      } else {  // the tail: pad the lanes past the run with copies of a valid point
        for (size_t l = 0; l < N; ++l) pad[a][l] = t[a][i + (l < m ? l : 0)];
        tv[a] = hn::Load(d, pad[a]);
        if (!base) continue;
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
      const size_t p = order[i + l];
      T* o = out + 3 * p;
      if (weights) {  // Blender's vertex group on the offset: w (F(x) - x), finite where the sum is
        for (int a = 0; a < 3; ++a) o[a] = static_cast<T>(weights[p] * lane[a][l]);
      } else {
        o[0] = lane[0][l], o[1] = lane[1][l], o[2] = lane[2][l];
      }
    }
  }
  return hn::AllTrue(d, hn::Eq(bad, bad));  // Highway 1.0's Ne is ordered: NaN != NaN is false
}

bool CellF32(const KernelAxis* axes, const float* block, const float* const* t, const float* const* base,
             const std::uint32_t* order, size_t count, float* out, const double* weights) {
  return CellKernel(axes, block, t, base, order, count, out, weights);
}
bool CellF64(const KernelAxis* axes, const double* block, const double* const* t, const double* const* base,
             const std::uint32_t* order, size_t count, double* out, const double* weights) {
  return CellKernel(axes, block, t, base, order, count, out, weights);
}

// D[c][a] = d/dt_a of component c of sum w_ijk block_ijk: the k sums of values and of
// derivatives along axis 2 share each (i, j) row of the block.
template <int W0, int W1, int W2, class D, class V, class T>
HWY_INLINE void ContractDerivative(D d, const T* block, const V* const w[3], const V* const dw[3], int n0, int n1,
                                   int n2, V out[3][3]) {
  const int c0 = W0 ? W0 : n0, c1 = W1 ? W1 : n1, c2 = W2 ? W2 : n2;
  for (int c = 0; c < 3; ++c) out[c][0] = out[c][1] = out[c][2] = hn::Zero(d);
  for (int i = 0; i < c0; ++i)
    for (int j = 0; j < c1; ++j) {
      const T* b = block + 3 * ((i * c1 + j) * c2);
      V r[3] = {hn::Zero(d), hn::Zero(d), hn::Zero(d)}, rd[3] = {hn::Zero(d), hn::Zero(d), hn::Zero(d)};
      for (int k = 0; k < c2; ++k)
        for (int c = 0; c < 3; ++c) {
          const V bc = hn::Set(d, b[3 * k + c]);
          r[c] = hn::MulAdd(w[2][k], bc, r[c]);
          rd[c] = hn::MulAdd(dw[2][k], bc, rd[c]);
        }
      const V a0 = hn::Mul(dw[0][i], w[1][j]), a1 = hn::Mul(w[0][i], dw[1][j]), a2 = hn::Mul(w[0][i], w[1][j]);
      for (int c = 0; c < 3; ++c) {
        out[c][0] = hn::MulAdd(a0, r[c], out[c][0]);
        out[c][1] = hn::MulAdd(a1, r[c], out[c][1]);
        out[c][2] = hn::MulAdd(a2, rd[c], out[c][2]);
      }
    }
}

template <CellDerivative kWhat, class T>
bool CellDerivatives(const KernelAxis* axes, const double* P, const double* weights, const CellRun<T>& run,
                     const T* normals, T* out, unsigned char* flags) {
  const hn::ScalableTag<T> d;
  using V = hn::Vec<decltype(d)>;
  constexpr size_t kMax = HWY_MAX_BYTES / sizeof(T);
  const size_t N = hn::Lanes(d);
  const bool cubic = axes[0].width == 4 && axes[1].width == 4 && axes[2].width == 4;
  V Pv[9];
  for (int e = 0; e < 9; ++e) Pv[e] = hn::Set(d, static_cast<T>(P[e]));
  const V one = hn::Set(d, T(1));
  HWY_ALIGN T pad[kMax], lane[9][kMax];
  std::uint32_t point[kMax];
  bool all_good = true;
  for (size_t i = 0; i < run.count; i += N) {
    const size_t m = run.count - i < N ? run.count - i : N;
    for (size_t l = 0; l < N; ++l) point[l] = run.order[i + (l < m ? l : 0)];  // the tail repeats a point
    auto load = [&](const T* src) HWY_ATTR {
      if (m == N) return hn::LoadU(d, src + i);
      for (size_t l = 0; l < N; ++l) pad[l] = src[i + (l < m ? l : 0)];
      return hn::Load(d, pad);
    };
    LaneTrouble<hn::ScalableTag<T>> trouble(d);
    V j[3][3];
    if (run.block) {
      V w[3][16], dw[3][16];
      for (int a = 0; a < 3; ++a) AxisWeights(d, axes[a], load(run.t[a]), w[a], dw[a]);
      const V* wp[3] = {w[0], w[1], w[2]};
      const V* dwp[3] = {dw[0], dw[1], dw[2]};
      V D[3][3];
      if (cubic) ContractDerivative<4, 4, 4>(d, run.block, wp, dwp, 4, 4, 4, D);
      else ContractDerivative<0, 0, 0>(d, run.block, wp, dwp, axes[0].width, axes[1].width, axes[2].width, D);
      for (int a = 0; a < 3; ++a) {
        const V ds = load(run.ds[a]);
        for (int c = 0; c < 3; ++c) D[c][a] = hn::Mul(D[c][a], ds);
      }
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
          j[r][c] = hn::MulAdd(D[r][0], Pv[c], hn::MulAdd(D[r][1], Pv[3 + c], hn::Mul(D[r][2], Pv[6 + c])));
      if (weights) {
        for (size_t l = 0; l < N; ++l) pad[l] = static_cast<T>(weights[point[l]]);
        const V wv = hn::Load(d, pad);
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) j[r][c] = hn::Mul(wv, j[r][c]);
      }
    } else {
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) j[r][c] = hn::Zero(d);
    }
    for (int r = 0; r < 3; ++r) j[r][r] = hn::Add(j[r][r], one);
    if (kWhat == CellDerivative::Jacobian) {
      for (int e = 0; e < 9; ++e) {
        trouble.mark(j[e / 3][e % 3]);
        hn::Store(j[e / 3][e % 3], d, lane[e]);
      }
      for (size_t l = 0; l < m; ++l)
        for (int e = 0; e < 9; ++e) out[9 * size_t(point[l]) + e] = lane[e][l];
    } else if (kWhat == CellDerivative::Determinant) {
      hn::Store(DeterminantLanes(j, trouble), d, lane[0]);
      for (size_t l = 0; l < m; ++l) out[point[l]] = lane[0][l];
    } else {
      for (size_t l = 0; l < N; ++l)
        for (int a = 0; a < 3; ++a) lane[a][l] = normals[3 * size_t(point[l]) + a];
      V nv[3] = {hn::Load(d, lane[0]), hn::Load(d, lane[1]), hn::Load(d, lane[2])};
      NormalLanes(j, nv, trouble);
      for (int a = 0; a < 3; ++a) hn::Store(nv[a], d, lane[a]);
      for (size_t l = 0; l < m; ++l)
        for (int a = 0; a < 3; ++a) out[3 * size_t(point[l]) + a] = lane[a][l];
    }
    if (!trouble.report(m, [&](size_t l) HWY_ATTR { flags[point[l]] = 1; })) all_good = false;
  }
  return all_good;
}

template <class T>
bool Derivatives(CellDerivative what, const KernelAxis* axes, const double* P, const double* weights,
                 const CellRun<T>& run, const T* normals, T* out, unsigned char* flags) {
  switch (what) {
    case CellDerivative::Jacobian:
      return CellDerivatives<CellDerivative::Jacobian>(axes, P, weights, run, normals, out, flags);
    case CellDerivative::Normal:
      return CellDerivatives<CellDerivative::Normal>(axes, P, weights, run, normals, out, flags);
    default:
      return CellDerivatives<CellDerivative::Determinant>(axes, P, weights, run, normals, out, flags);
  }
}

bool DerivativesF64(CellDerivative what, const KernelAxis* axes, const double* P, const double* weights,
                    const CellRun<double>& run, const double* normals, double* out, unsigned char* flags) {
  return Derivatives(what, axes, P, weights, run, normals, out, flags);
}
// float32 carries normals only (what a viewport draws); J and det J are handed back in double.
bool NormalsF32(CellDerivative, const KernelAxis* axes, const double* P, const double* weights,
                const CellRun<float>& run, const float* normals, float* out, unsigned char* flags) {
  return CellDerivatives<CellDerivative::Normal>(axes, P, weights, run, normals, out, flags);
}

}  // namespace HWY_NAMESPACE
}  // namespace deformkit
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace deformkit {

HWY_EXPORT(CellF32);
HWY_EXPORT(CellF64);
HWY_EXPORT(DerivativesF64);
HWY_EXPORT(NormalsF32);

bool lattice_cell_derivatives(CellDerivative what, const KernelAxis axes[3], const double P[9], const double* weights,
                              const CellRun<double>& run, const double* normals, double* out, unsigned char* flags) {
  return HWY_DYNAMIC_DISPATCH(DerivativesF64)(what, axes, P, weights, run, normals, out, flags);
}
bool lattice_cell_derivatives(CellDerivative what, const KernelAxis axes[3], const double P[9], const double* weights,
                              const CellRun<float>& run, const float* normals, float* out, unsigned char* flags) {
  if (what != CellDerivative::Normal) throw std::logic_error("lattice_cell_derivatives: float32 carries normals only");
  return HWY_DYNAMIC_DISPATCH(NormalsF32)(what, axes, P, weights, run, normals, out, flags);
}

bool lattice_cell_kernel(const KernelAxis axes[3], const float* block, const float* const t[3],
                         const float* const base[3], const std::uint32_t* order, std::size_t count, float* out,
                         const double* weights) {
  return HWY_DYNAMIC_DISPATCH(CellF32)(axes, block, t, base, order, count, out, weights);
}
bool lattice_cell_kernel(const KernelAxis axes[3], const double* block, const double* const t[3],
                         const double* const base[3], const std::uint32_t* order, std::size_t count, double* out,
                         const double* weights) {
  return HWY_DYNAMIC_DISPATCH(CellF64)(axes, block, t, base, order, count, out, weights);
}

}  // namespace deformkit
#endif  // HWY_ONCE
