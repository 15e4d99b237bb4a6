// Each axis' weight functions over a cell in Bernstein form, what the cells' det J coefficients
// are built from (docs/math/lattice.md, "Certified volume-ratio bounds").
#include "lattice/cell_volume_ratio.hpp"

#include <algorithm>

namespace deformkit {

namespace {

// c on [0,1] re-expressed over [lo, hi]: coefficient i is the blossom at (lo^(n-i), hi^i).
void reparameterise(double* c, int n, int stride, double lo, double hi) {
  double out[kMaxAxisWidth], work[kMaxAxisWidth];
  for (int i = 0; i <= n; ++i) {
    for (int q = 0; q <= n; ++q) work[q] = c[q * stride];
    for (int level = 0; level < n; ++level) {
      const double t = level < n - i ? lo : hi;
      for (int q = 0; q < n - level; ++q) work[q] = (1.0 - t) * work[q] + t * work[q + 1];
    }
    out[i] = work[0];
  }
  for (int i = 0; i <= n; ++i) c[i * stride] = out[i];
}

}  // namespace

AxisForm axis_form(const AxisBasis& axis, const CellSpec& cell, int a) {
  AxisForm f;
  AxisSpan span;
  span.piece = cell.piece[a];
  span.t = cell.lo[a];
  double w[kMaxAxisWidth], w1[kMaxAxisWidth], d0[4], d1[4];
  const bool single = is_blender(axis.kind) && axis.count == 1;
  if (cell.frozen[a] || single) {
    span.frozen = true;
    axis.evaluate(span, w, nullptr, f.index);
    f.degree = 0;
    f.width = axis.width();
    for (int k = 0; k < f.width; ++k) f.b[k] = w[k];
  } else {
    axis.evaluate(span, w, nullptr, f.index);  // the indices; the weights come below
    f.width = axis.width();
    switch (axis.kind) {
      case BasisKind::Bernstein:
      case BasisKind::BezierBlocks:
        f.degree = f.width - 1;
        std::fill(f.b, f.b + f.width * f.width, 0.0);
        for (int q = 0; q <= f.degree; ++q) f.b[q * f.width + q] = 1.0;
        break;
      case BasisKind::BlenderLinear:
        f.degree = 1;
        blender_key_weights(axis.kind, 0.0, w, d0);
        blender_key_weights(axis.kind, 1.0, w1, d1);
        for (int k = 0; k < 4; ++k) f.b[k] = w[k], f.b[4 + k] = w1[k];
        break;
      default: {
        // A cubic's Bezier points from its Hermite data at the ends: b1 = p(0) + p'(0)/3, b2 = p(1) - p'(1)/3.
        const BasisKind kind = axis.kind == BasisKind::UniformBSpline ? BasisKind::BlenderBSpline : axis.kind;
        f.degree = 3;
        blender_key_weights(kind, 0.0, w, d0);
        blender_key_weights(kind, 1.0, w1, d1);
        for (int k = 0; k < 4; ++k) {
          f.b[k] = w[k];
          f.b[4 + k] = w[k] + d0[k] / 3.0;
          f.b[8 + k] = w1[k] - d1[k] / 3.0;
          f.b[12 + k] = w1[k];
        }
      }
    }
    if (cell.lo[a] != 0.0 || cell.hi[a] != 1.0)
      for (int k = 0; k < f.width; ++k) reparameterise(f.b + k, f.degree, f.width, cell.lo[a], cell.hi[a]);
  }
  // Weights that vanish over the whole cell (Blender's linear and clamped indices) are dropped.
  int kept = 0;
  for (int k = 0; k < f.width; ++k) {
    bool zero = true;
    for (int q = 0; q <= f.degree; ++q) zero = zero && f.b[q * f.width + k] == 0.0;
    if (zero) continue;
    f.index[kept] = f.index[k];
    for (int q = 0; q <= f.degree; ++q) f.b[q * f.width + kept] = f.b[q * f.width + k];
    ++kept;
  }
  // Compact the rows to the kept width.
  for (int q = 0; q <= f.degree; ++q)
    for (int k = 0; k < kept; ++k) f.b[q * kept + k] = f.b[q * f.width + k];
  f.width = kept;
  f.identity = f.width == f.degree + 1;
  for (int q = 0; q <= f.degree && f.identity; ++q)
    for (int k = 0; k < kept; ++k) f.identity = f.identity && f.b[q * kept + k] == (q == k ? 1.0 : 0.0);
  return f;
}

}  // namespace deformkit
