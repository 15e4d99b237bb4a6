// Per cell, det J of a box lattice as a trivariate Bernstein polynomial (docs/math/lattice.md,
// "Certified volume-ratio bounds"): each axis' weight functions of the cell's piece in Bernstein
// form, the displacement's Bezier net by contracting the control-point offsets with them, its
// derivative nets, then det(I + K) with K = A dD/ds (A = d(s)/dx) expanded in the scaled form.
#include "lattice/cell_volume_ratio.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <tuple>

namespace deformkit {

namespace {

// One axis over one cell: the control points it touches and the Bernstein coefficients, over
// the cell's [lo, hi], of the weight of each: b[q * width + w].
struct AxisForm {
  int degree = 0;
  int width = 0;
  int index[kMaxAxisWidth] = {};
  double b[kMaxAxisWidth * kMaxAxisWidth] = {};
};

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
  return f;
}

// max_q sum_w |b[q][w]|: how much the contraction along this axis can magnify magnitudes.
double abs_row_sum(const AxisForm& f) {
  double m = 0.0;
  for (int q = 0; q <= f.degree; ++q) {
    double s = 0.0;
    for (int k = 0; k < f.width; ++k) s += std::abs(f.b[q * f.width + k]);
    m = std::max(m, s);
  }
  return m;
}

struct Workspace {
  std::vector<double> block, t1, t2;
  TriPoly net[3];     // the displacement's Bezier net, per component
  TriPoly k[3][3];    // K[row][column], scaled form
  TriPoly p, q, r, scratch;
};

// D's Bezier net over the cell (up to a constant), per component: the offsets contracted axis by axis.
void displacement_net(const LatticeView& v, const AxisForm f[3], Workspace& ws, double& max_offset) {
  const auto res = v.lattice->resolution();
  const int w0 = f[0].width, w1 = f[1].width, w2 = f[2].width;
  const int n0 = f[0].degree + 1, n1 = f[1].degree + 1, n2 = f[2].degree + 1;
  ws.block.assign(std::size_t(3) * w0 * w1 * w2, 0.0);
  double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (int p = 0; p < w0; ++p)
    for (int q = 0; q < w1; ++q)
      for (int r = 0; r < w2; ++r) {
        const double* o = &v.offset[3 * ((std::size_t(f[0].index[p]) * res[1] + f[1].index[q]) * res[2] + f[2].index[r])];
        for (int c = 0; c < 3; ++c) {
          ws.block[((std::size_t(p) * w1 + q) * w2 + r) * 3 + c] = o[c];
          lo[c] = std::min(lo[c], o[c]), hi[c] = std::max(hi[c], o[c]);
        }
      }
  // The weights sum to 1, so a constant taken off every offset leaves the derivatives as they
  // are: the offsets' midrange goes, and a translated cell has K = 0 exactly, with no rounding.
  max_offset = 0.0;
  for (std::size_t e = 0; e < ws.block.size(); ++e) {
    const int c = int(e % 3);
    ws.block[e] -= 0.5 * (lo[c] + hi[c]);
    max_offset = std::max(max_offset, std::abs(ws.block[e]));
  }
  // Along axis 2: t1[p][q][k][c], then axis 1: t2[p][j][k][c], then axis 0 into the nets.
  ws.t1.assign(std::size_t(3) * w0 * w1 * n2, 0.0);
  for (int p = 0; p < w0; ++p)
    for (int q = 0; q < w1; ++q)
      for (int k = 0; k < n2; ++k)
        for (int r = 0; r < w2; ++r) {
          const double b = f[2].b[k * w2 + r];
          const double* src = &ws.block[((std::size_t(p) * w1 + q) * w2 + r) * 3];
          double* dst = &ws.t1[((std::size_t(p) * w1 + q) * n2 + k) * 3];
          for (int c = 0; c < 3; ++c) dst[c] += b * src[c];
        }
  ws.t2.assign(std::size_t(3) * w0 * n1 * n2, 0.0);
  for (int p = 0; p < w0; ++p)
    for (int j = 0; j < n1; ++j)
      for (int q = 0; q < w1; ++q) {
        const double b = f[1].b[j * w1 + q];
        for (int k = 0; k < n2; ++k) {
          const double* src = &ws.t1[((std::size_t(p) * w1 + q) * n2 + k) * 3];
          double* dst = &ws.t2[((std::size_t(p) * n1 + j) * n2 + k) * 3];
          for (int c = 0; c < 3; ++c) dst[c] += b * src[c];
        }
      }
  for (int c = 0; c < 3; ++c) ws.net[c].reset({f[0].degree, f[1].degree, f[2].degree});
  for (int i = 0; i < n0; ++i)
    for (int p = 0; p < w0; ++p) {
      const double b = f[0].b[i * w0 + p];
      for (int j = 0; j < n1; ++j)
        for (int k = 0; k < n2; ++k) {
          const double* src = &ws.t2[((std::size_t(p) * n1 + j) * n2 + k) * 3];
          for (int c = 0; c < 3; ++c) ws.net[c].at(i, j, k) += b * src[c];
        }
    }
}

// Column a of K = A dD/ds over the cell, scaled form: factor * A * (the net's forward
// differences along a) (Sederberg-Parry 1986 eq. 5: a Bezier derivative is n times the differences).
void jacobian_column(const LatticeView& v, Workspace& in, int a, double factor) {
  TriPoly* out[3] = {&in.k[0][a], &in.k[1][a], &in.k[2][a]};
  std::array<int, 3> d = in.net[0].degree;
  const int n = d[a];
  d[a] = n - 1;
  for (int r = 0; r < 3; ++r) out[r]->reset(d);
  for (int i = 0; i <= d[0]; ++i)
    for (int j = 0; j <= d[1]; ++j)
      for (int k = 0; k <= d[2]; ++k) {
        const int i1 = i + (a == 0), j1 = j + (a == 1), k1 = k + (a == 2);
        double diff[3];
        for (int c = 0; c < 3; ++c) diff[c] = n * factor * (in.net[c].at(i1, j1, k1) - in.net[c].at(i, j, k));
        for (int r = 0; r < 3; ++r)
          out[r]->at(i, j, k) = v.to_box(r, 0) * diff[0] + v.to_box(r, 1) * diff[1] + v.to_box(r, 2) * diff[2];
      }
  for (int r = 0; r < 3; ++r) to_scaled(*out[r]);
}

}  // namespace

LatticeView::LatticeView(const BoxLattice& l) : lattice(&l), to_box(l.box().to_box) {
  const auto& c = l.control_points();
  const auto& r = l.rest_control_points();
  offset.resize(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    offset[i] = l.strength() * (c[i] - r[i]);
    at_rest = at_rest && offset[i] == 0.0;
  }
}

CellVolumeRatio cell_volume_ratio(const LatticeView& v, const CellSpec& cell) {
  thread_local Workspace ws;
  const LatticeAxes& axes = v.lattice->axes();
  AxisForm f[3];
  for (int a = 0; a < 3; ++a) f[a] = axis_form(axes[a], cell, a);
  double max_offset = 0.0;
  displacement_net(v, f, ws, max_offset);
  // det(I + K) = 1 + tr K + (principal 2x2 minors) + det K: exactly 1 where K vanishes.
  bool present[3];
  std::array<int, 3> result{0, 0, 0};
  double kappa = 0.0;  // a bound on |K|'s coefficients, for the rounding allowance
  const double a_norm = v.to_box.cwiseAbs().rowwise().sum().maxCoeff();
  const double beta = abs_row_sum(f[0]) * abs_row_sum(f[1]) * abs_row_sum(f[2]);
  for (int a = 0; a < 3; ++a) {
    present[a] = f[a].degree > 0;
    if (!present[a]) {
      for (int r = 0; r < 3; ++r) ws.k[r][a].clear();
      continue;
    }
    const double factor = axes[a].scale() / (cell.hi[a] - cell.lo[a]);
    jacobian_column(v, ws, a, factor);
    for (int b = 0; b < 3; ++b) result[b] += ws.k[0][a].degree[b];
    kappa = std::max(kappa, 2.0 * f[a].degree * std::abs(factor) * a_norm * beta * max_offset);
  }
  CellVolumeRatio out;
  TriPoly& acc = out.coefficients;
  acc.reset(result);
  {
    std::size_t e = 0;
    for (int i = 0; i <= result[0]; ++i)
      for (int j = 0; j <= result[1]; ++j)
        for (int k = 0; k <= result[2]; ++k, ++e)
          acc.c[e] = binomial(result[0], i) * binomial(result[1], j) * binomial(result[2], k);
  }
  if (!v.at_rest) {
    auto& K = ws.k;
    for (int a = 0; a < 3; ++a) add_elevated_scaled(K[a][a], acc, ws.scratch);
    // Principal minors (a, b) for a < b: K_aa K_bb - K_ba K_ab.
    for (int a = 0; a < 3; ++a)
      for (int b = a + 1; b < 3; ++b) {
        if (!present[a] || !present[b]) continue;
        multiply_scaled(K[a][a], K[b][b], ws.p);
        multiply_scaled(K[b][a], K[a][b], ws.q);
        for (std::size_t e = 0; e < ws.p.c.size(); ++e) ws.p.c[e] -= ws.q.c[e];
        add_elevated_scaled(ws.p, acc, ws.scratch);
      }
    if (present[0] && present[1] && present[2]) {
      // det K along column 0: sum_r (-1)^r K_r0 (minor of rows other than r, columns 1 and 2).
      const int rows[3][2] = {{1, 2}, {0, 2}, {0, 1}};
      for (int r = 0; r < 3; ++r) {
        const int x = rows[r][0], y = rows[r][1];
        multiply_scaled(K[x][1], K[y][2], ws.p);
        multiply_scaled(K[y][1], K[x][2], ws.q);
        for (std::size_t e = 0; e < ws.p.c.size(); ++e) ws.p.c[e] -= ws.q.c[e];
        multiply_scaled(K[r][0], ws.p, ws.r);
        if (r == 1)
          for (double& c : ws.r.c) c = -c;
        add_elevated_scaled(ws.r, acc, ws.scratch);
      }
    }
  }
  from_scaled(acc);
  // Forward error of the above: each step sums at most `terms` products with non-negative
  // binomial weights, over terms of magnitude at most 3 kappa + 6 kappa^2 + 6 kappa^3.
  if (kappa > 0.0) {
    const std::size_t column = ws.k[0][present[0] ? 0 : present[1] ? 1 : 2].c.size();
    const double terms = 3.0 * double(column) + f[0].width + f[1].width + f[2].width + 3.0 * (result[0] + result[1] + result[2]);
    const double eps = std::numeric_limits<double>::epsilon();
    double max_abs = 0.0;
    for (double c : acc.c) max_abs = std::max(max_abs, std::abs(c));
    out.rounding = 8.0 * terms * eps * (3.0 * kappa + 6.0 * kappa * kappa + 6.0 * kappa * kappa * kappa) + eps * max_abs;
  }
  return out;
}

CellVolumeRatio cell_volume_ratio(const BoxLattice& lattice, const CellSpec& cell) {
  return cell_volume_ratio(LatticeView(lattice), cell);
}

double cell_rest_volume(const BoxLattice& lattice, const CellSpec& cell) {
  double v = std::abs(lattice.box().edges.determinant());
  for (int a = 0; a < 3; ++a) v *= (cell.frozen[a] ? 1.0 : cell.hi[a] - cell.lo[a]) / lattice.axes()[a].scale();
  return v;
}

std::vector<CellSpec> region_cells(const BoxLattice& lattice) {
  const LatticeAxes& axes = lattice.axes();
  std::vector<CellSpec> cells;
  cells.reserve(std::size_t(axes[0].pieces()) * axes[1].pieces() * axes[2].pieces());
  for (int i = 0; i < axes[0].pieces(); ++i)
    for (int j = 0; j < axes[1].pieces(); ++j)
      for (int k = 0; k < axes[2].pieces(); ++k) {
        CellSpec c;
        c.piece = {i, j, k};
        for (int a = 0; a < 3; ++a)
          if (is_blender(axes[a].kind) && axes[a].count == 1) c.frozen[a] = true, c.lo[a] = c.hi[a] = 0.0;
        cells.push_back(c);
      }
  return cells;
}

std::vector<CellSpec> cells_holding(const BoxLattice& lattice, const double* points, std::size_t n,
                                    bool& identity_points) {
  require_finite_rows(points, n, "points");
  const LatticeAxes& axes = lattice.axes();
  const Outside outside = lattice.outside();
  identity_points = false;
  // Key: piece, frozen and (frozen) the fixed t per axis; value: the cell, its t range widened.
  std::map<std::tuple<int, int, int, int, double, double, double>, CellSpec> found;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 s = lattice.box().coordinates(Vec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]));
    if (!s.allFinite())
      throw std::invalid_argument("points: row " + std::to_string(i) + " lies so far away that its lattice "
                                  "coordinates overflow");
    CellSpec c;
    bool inside = true;
    AxisSpan span[3];
    for (int a = 0; a < 3; ++a) {
      span[a] = axes[a].locate(s[a], outside);
      inside = inside && span[a].inside;
    }
    if (!inside && outside == Outside::Unchanged) {
      identity_points = true;
      continue;
    }
    if (outside == Outside::Extrapolate && lattice.extrapolation_gain(s) > ControlLattice::kMaxExtrapolationGain)
      throw std::invalid_argument("points: row " + std::to_string(i) + " lies too far outside the lattice for "
                                  "'extrapolate' to evaluate it accurately (docs/lattice.md, \"Far outside\")");
    int flags = 0;
    for (int a = 0; a < 3; ++a) {
      c.piece[a] = span[a].piece;
      const bool single = is_blender(axes[a].kind) && axes[a].count == 1;
      c.frozen[a] = span[a].frozen || single;
      // Blender's frozen cells put every weight on one control point: t does not matter there.
      const double t = c.frozen[a] ? (is_blender(axes[a].kind) ? 0.0 : span[a].t) : 0.0;
      c.lo[a] = c.frozen[a] ? t : std::min(0.0, span[a].t);
      c.hi[a] = c.frozen[a] ? t : std::max(1.0, span[a].t);
      flags |= int(c.frozen[a]) << a;
    }
    const auto key = std::make_tuple(c.piece[0], c.piece[1], c.piece[2], flags, c.frozen[0] ? c.lo[0] : 0.0,
                                     c.frozen[1] ? c.lo[1] : 0.0, c.frozen[2] ? c.lo[2] : 0.0);
    auto [it, fresh] = found.emplace(key, c);
    if (!fresh)
      for (int a = 0; a < 3; ++a)
        if (!c.frozen[a]) {
          it->second.lo[a] = std::min(it->second.lo[a], c.lo[a]);
          it->second.hi[a] = std::max(it->second.hi[a], c.hi[a]);
        }
  }
  std::vector<CellSpec> cells;
  cells.reserve(found.size());
  for (auto& kv : found) cells.push_back(kv.second);
  return cells;
}

std::vector<std::array<int, 3>> cell_control_indices(const BoxLattice& lattice, const std::array<int, 3>& cell) {
  const LatticeAxes& axes = lattice.axes();
  CellSpec spec;
  spec.piece = cell;
  std::vector<int> index[3];
  for (int a = 0; a < 3; ++a) {
    const int lo = is_blender(axes[a].kind) ? -2 : 0;
    const int hi = is_blender(axes[a].kind) ? axes[a].count : axes[a].pieces() - 1;
    if (cell[a] < lo || cell[a] > hi)
      throw std::invalid_argument("cell: index " + std::to_string(cell[a]) + " along axis " + std::to_string(a) +
                                  " is outside " + std::to_string(lo) + ".." + std::to_string(hi));
    if (is_blender(axes[a].kind) && axes[a].count == 1) spec.frozen[a] = true, spec.hi[a] = 0.0;
    if (is_blender(axes[a].kind) && (cell[a] <= -2 || cell[a] >= axes[a].count)) spec.frozen[a] = true, spec.hi[a] = 0.0;
    const AxisForm f = axis_form(axes[a], spec, a);
    for (int k = 0; k < f.width; ++k)
      if (std::find(index[a].begin(), index[a].end(), f.index[k]) == index[a].end()) index[a].push_back(f.index[k]);
    std::sort(index[a].begin(), index[a].end());
  }
  std::vector<std::array<int, 3>> out;
  for (int i : index[0])
    for (int j : index[1])
      for (int k : index[2]) out.push_back({i, j, k});
  return out;
}

}  // namespace deformkit
