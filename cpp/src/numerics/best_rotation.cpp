// Compiled once per x86 target by Highway and dispatched at run time: no -march needed.
#include "deformkit/numerics/best_rotation.hpp"

#include <Eigen/SVD>

#include <cmath>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "numerics/best_rotation.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"

// Newton stops when no entry changes by more than this; its quadratic convergence then leaves the
// iterate orthogonal to machine precision.
#define DEFORMKIT_POLAR_TOLERANCE 1e-13
#define DEFORMKIT_POLAR_MAX_STEPS 30

HWY_BEFORE_NAMESPACE();
namespace deformkit {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Matrices [begin, end) (a whole number of vectors); needs_svd[i - begin] marks those whose
// det(S) <= 1e-6 max|S|^3, left for the SVD.
HWY_NOINLINE void NewtonPolar(const double* s, double* r, size_t count, size_t begin, size_t end,
                              unsigned char* needs_svd) {
  const hn::ScalableTag<double> d;
  using V = hn::Vec<decltype(d)>;
  const size_t lanes = hn::Lanes(d);
  const V half = hn::Set(d, 0.5), tolerance = hn::Set(d, DEFORMKIT_POLAR_TOLERANCE);
  for (size_t i = begin; i + lanes <= end; i += lanes) {
    V x[9];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) x[3 * a + b] = hn::LoadU(d, s + (3 * b + a) * count + i);  // X = S^T
    V scale = hn::Abs(x[0]);
    for (int k = 1; k < 9; ++k) scale = hn::Max(scale, hn::Abs(x[k]));
    const auto nonzero = hn::Gt(scale, hn::Zero(d));
    const V inv_scale = hn::IfThenElse(nonzero, hn::Div(hn::Set(d, 1.0), scale), hn::Zero(d));
    for (int k = 0; k < 9; ++k) x[k] = hn::Mul(x[k], inv_scale);
    auto cofactors = [&](V* c) {
      c[0] = hn::NegMulAdd(x[5], x[7], hn::Mul(x[4], x[8]));
      c[1] = hn::NegMulAdd(x[3], x[8], hn::Mul(x[5], x[6]));
      c[2] = hn::NegMulAdd(x[4], x[6], hn::Mul(x[3], x[7]));
      c[3] = hn::NegMulAdd(x[1], x[8], hn::Mul(x[2], x[7]));
      c[4] = hn::NegMulAdd(x[2], x[6], hn::Mul(x[0], x[8]));
      c[5] = hn::NegMulAdd(x[0], x[7], hn::Mul(x[1], x[6]));
      c[6] = hn::NegMulAdd(x[2], x[4], hn::Mul(x[1], x[5]));
      c[7] = hn::NegMulAdd(x[0], x[5], hn::Mul(x[2], x[3]));
      c[8] = hn::NegMulAdd(x[1], x[3], hn::Mul(x[0], x[4]));
      return hn::MulAdd(x[0], c[0], hn::MulAdd(x[1], c[1], hn::Mul(x[2], c[2])));  // det X
    };
    V c[9];
    const auto good = hn::And(nonzero, hn::Gt(cofactors(c), hn::Set(d, 1e-6)));
    const auto good_mask = hn::VecFromMask(d, good);
    for (int k = 0; k < 9; ++k) x[k] = hn::IfThenElse(good, x[k], hn::Set(d, k % 4 == 0 ? 1.0 : 0.0));
    for (int step = 0; step < DEFORMKIT_POLAR_MAX_STEPS; ++step) {
      const V det = cofactors(c);  // X^-T = cof(X) / det X
      const V inv_det = hn::Div(hn::Set(d, 1.0), det);
      V nx = hn::Zero(d), nc = hn::Zero(d);
      for (int k = 0; k < 9; ++k) {
        c[k] = hn::Mul(c[k], inv_det);
        nx = hn::MulAdd(x[k], x[k], nx);
        nc = hn::MulAdd(c[k], c[k], nc);
      }
      const V g = hn::Sqrt(hn::Sqrt(hn::Div(nc, nx)));  // Frobenius-norm scaling
      const V inv_g = hn::Div(hn::Set(d, 1.0), g);
      V change = hn::Zero(d);
      for (int k = 0; k < 9; ++k) {
        const V next = hn::Mul(half, hn::MulAdd(g, x[k], hn::Mul(inv_g, c[k])));
        change = hn::Max(change, hn::Abs(hn::Sub(next, x[k])));
        x[k] = next;
      }
      if (hn::AllTrue(d, hn::Le(change, tolerance))) break;
    }
    for (int k = 0; k < 9; ++k) hn::StoreU(x[k], d, r + k * count + i);
    HWY_ALIGN double flags[HWY_MAX_BYTES / sizeof(double)];
    hn::Store(good_mask, d, flags);
    for (size_t l = 0; l < lanes; ++l) needs_svd[i + l - begin] = flags[l] == 0.0;
  }
}

size_t LaneCount() { return hn::Lanes(hn::ScalableTag<double>()); }

}  // namespace HWY_NAMESPACE
}  // namespace deformkit
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace deformkit {

HWY_EXPORT(NewtonPolar);
HWY_EXPORT(LaneCount);

namespace {

Mat3 svd_rotation(const Mat3& s) {
  const Eigen::JacobiSVD<Mat3> svd(s, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 u = svd.matrixU();
  Mat3 r = svd.matrixV() * u.transpose();
  if (r.determinant() < 0) {
    u.col(2) *= -1.0;  // the singular vector of the smallest singular value
    r = svd.matrixV() * u.transpose();
  }
  return r;
}

}  // namespace

Mat3 best_rotation(const Mat3& s) {
  const double scale = s.cwiseAbs().maxCoeff();
  if (!(scale > 0)) return Mat3::Identity();
  Mat3 x = s.transpose() / scale;
  if (!(x.determinant() > 1e-6)) return svd_rotation(s);
  for (int it = 0; it < DEFORMKIT_POLAR_MAX_STEPS; ++it) {
    const Mat3 inv_t = x.inverse().transpose();
    const double g = std::sqrt(std::sqrt(inv_t.squaredNorm() / x.squaredNorm()));
    const Mat3 next = 0.5 * (g * x + inv_t / g);
    const double change = (next - x).cwiseAbs().maxCoeff();
    x = next;
    if (change <= DEFORMKIT_POLAR_TOLERANCE) break;
  }
  return x;
}

void best_rotations(const double* s, double* r, std::size_t count) {
  const std::size_t lanes = HWY_DYNAMIC_DISPATCH(LaneCount)();
  const std::size_t full = count - count % lanes;
  constexpr std::size_t kBlock = 256;  // lanes' SVD flags per call
  unsigned char needs_svd[kBlock];
  auto load = [&](std::size_t i) {
    Mat3 m;
    for (int k = 0; k < 9; ++k) m(k / 3, k % 3) = s[std::size_t(k) * count + i];
    return m;
  };
  auto store = [&](std::size_t i, const Mat3& m) {
    for (int k = 0; k < 9; ++k) r[std::size_t(k) * count + i] = m(k / 3, k % 3);
  };
  for (std::size_t begin = 0; begin < full; begin += kBlock) {
    const std::size_t end = std::min(full, begin + kBlock);
    HWY_DYNAMIC_DISPATCH(NewtonPolar)(s, r, count, begin, end, needs_svd);
    for (std::size_t i = begin; i < end; ++i)
      if (needs_svd[i - begin]) store(i, best_rotation(load(i)));  // zero S -> I, else the SVD
  }
  for (std::size_t i = full; i < count; ++i) store(i, best_rotation(load(i)));
}

}  // namespace deformkit
#endif  // HWY_ONCE
