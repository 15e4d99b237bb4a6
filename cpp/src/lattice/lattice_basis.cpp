#include "deformkit/lattice/lattice_basis.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace deformkit {

void bernstein_basis(int degree, double t, double* value, double* derivative) {
  // B_i^d = C(d,i) t^i (1-t)^(d-i); dB_i^d/dt = d (B_{i-1}^{d-1} - B_i^{d-1}) (docs/math/lattice.md).
  double lower[kMaxAxisWidth + 1];
  auto fill = [t](int d, double* out) {
    double tp[kMaxAxisWidth + 1], up[kMaxAxisWidth + 1];
    tp[0] = up[0] = 1.0;
    for (int i = 1; i <= d; ++i) {
      tp[i] = tp[i - 1] * t;
      up[i] = up[i - 1] * (1.0 - t);
    }
    double binom = 1.0;
    for (int i = 0; i <= d; ++i) {
      out[i] = binom * tp[i] * up[d - i];
      binom = binom * (d - i) / (i + 1);
    }
  };
  fill(degree, value);
  if (!derivative) return;
  if (degree == 0) {
    derivative[0] = 0.0;
    return;
  }
  fill(degree - 1, lower);
  for (int i = 0; i <= degree; ++i)
    derivative[i] = degree * ((i > 0 ? lower[i - 1] : 0.0) - (i < degree ? lower[i] : 0.0));
}

void blender_key_weights(BasisKind kind, double t, double w[4], double dw[4]) {
  const double t2 = t * t, t3 = t2 * t;
  switch (kind) {
    case BasisKind::BlenderLinear:
      w[0] = 0.0, w[1] = 1.0 - t, w[2] = t, w[3] = 0.0;
      dw[0] = 0.0, dw[1] = -1.0, dw[2] = 1.0, dw[3] = 0.0;
      return;
    case BasisKind::BlenderCardinal:
    case BasisKind::BlenderCatmullRom: {
      // key.cc: cardinal tension fc = 0.71, Catmull-Rom the same with fc = 0.5.
      const double fc = kind == BasisKind::BlenderCardinal ? 0.71 : 0.5;
      w[0] = -fc * t3 + 2.0 * fc * t2 - fc * t;
      w[1] = (2.0 - fc) * t3 + (fc - 3.0) * t2 + 1.0;
      w[2] = (fc - 2.0) * t3 + (3.0 - 2.0 * fc) * t2 + fc * t;
      w[3] = fc * t3 - fc * t2;
      dw[0] = -3.0 * fc * t2 + 4.0 * fc * t - fc;
      dw[1] = 3.0 * (2.0 - fc) * t2 + 2.0 * (fc - 3.0) * t;
      dw[2] = 3.0 * (fc - 2.0) * t2 + 2.0 * (3.0 - 2.0 * fc) * t + fc;
      dw[3] = 3.0 * fc * t2 - 2.0 * fc * t;
      return;
    }
    default: {
      // Uniform cubic B-spline (docs/math/lattice.md, "Uniform cubic B-spline").
      const double u = 1.0 - t;
      w[0] = u * u * u / 6.0;
      w[1] = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0;
      w[2] = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0;
      w[3] = t3 / 6.0;
      dw[0] = -0.5 * u * u;
      dw[1] = 1.5 * t2 - 2.0 * t;
      dw[2] = -1.5 * t2 + t + 0.5;
      dw[3] = 0.5 * t2;
      return;
    }
  }
}

AxisBasis AxisBasis::make(BasisKind kind, int count, const char* argument) {
  const std::string name(argument);
  switch (kind) {
    case BasisKind::Bernstein:
      if (count < 2 || count > kMaxAxisWidth)
        throw std::invalid_argument(name + ": must be 1.." + std::to_string(kMaxAxisWidth - 1) + " per axis, got " +
                                    std::to_string(count - 1));
      break;
    case BasisKind::BezierBlocks:
      if (count < 4 || (count - 1) % 3 != 0)
        throw std::invalid_argument(name + ": a cubic Bezier block lattice needs 3k+1 >= 4 control points per axis, got " +
                                    std::to_string(count));
      break;
    case BasisKind::UniformBSpline:
      if (count < 4 || count > 4096)
        throw std::invalid_argument(name + ": a cubic B-spline lattice needs 4..4096 control points per axis, got " +
                                    std::to_string(count));
      break;
    default:
      if (count < 1 || count > kMaxBlenderResolution)
        throw std::invalid_argument(name + ": Blender lattices have 1.." + std::to_string(kMaxBlenderResolution) +
                                    " points per axis, got " + std::to_string(count));
  }
  AxisBasis a;
  a.kind = kind;
  a.count = count;
  switch (kind) {
    case BasisKind::Bernstein: a.pieces_ = 1; break;
    case BasisKind::BezierBlocks: a.pieces_ = (count - 1) / 3; break;
    case BasisKind::UniformBSpline: a.pieces_ = count - 3; break;
    default: a.pieces_ = count > 1 ? count - 1 : 1;
  }
  // The B-spline covers the box's inner part: its rest control points span the whole box.
  a.lo_ = kind == BasisKind::UniformBSpline ? 1.0 / (count - 1) : 0.0;
  a.hi_ = kind == BasisKind::UniformBSpline ? (count - 2.0) / (count - 1) : 1.0;
  a.scale_ = a.pieces_ / (a.hi_ - a.lo_);
  return a;
}

void AxisBasis::evaluate(const AxisSpan& span, double* w, double* dw, int* index) const {
  double scratch[kMaxAxisWidth];
  double* d = dw ? dw : scratch;
  switch (kind) {
    case BasisKind::Bernstein:
      bernstein_basis(count - 1, span.t, w, d);
      for (int a = 0; a < count; ++a) index[a] = a;
      break;
    case BasisKind::BezierBlocks:
      bernstein_basis(3, span.t, w, d);
      for (int a = 0; a < 4; ++a) index[a] = 3 * span.piece + a;
      break;
    case BasisKind::UniformBSpline:
      blender_key_weights(BasisKind::BlenderBSpline, span.t, w, d);
      for (int a = 0; a < 4; ++a) index[a] = span.piece + a;
      break;
    default:
      if (count == 1) {
        for (int a = 0; a < 4; ++a) w[a] = a == 1 ? 1.0 : 0.0, d[a] = 0.0, index[a] = 0;
        return;
      }
      blender_key_weights(kind, span.t, w, d);
      for (int a = 0; a < 4; ++a) index[a] = std::clamp(span.piece - 1 + a, 0, count - 1);
  }
  if (!dw) return;
  const double k = span.frozen ? 0.0 : scale();
  for (int a = 0; a < width(); ++a) dw[a] *= k;
}

}  // namespace deformkit
