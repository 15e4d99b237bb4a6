// Per cell, det J of a box lattice as a trivariate Bernstein polynomial (docs/math/lattice.md,
// "Certified volume-ratio bounds"): each axis' weight functions of the cell's piece in Bernstein
// form, the displacement's Bezier net by contracting the control-point offsets with them, its
// derivative nets, then det(I + K) with K = A dD/ds (A = d(s)/dx), column by column in the scaled form.
#include "lattice/cell_volume_ratio.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace deformkit {

namespace {

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

// Forward error bound of det M's coefficients: each step sums at most `terms` products with
// non-negative binomial weights, of entries of magnitude at most 1 + kappa (six terms in a
// determinant), after the contraction of the offsets (the bases' widths).
double rounding_allowance(double kappa, std::size_t column, const AxisForm* const f[3]) {
  const double terms = 3.0 * double(column) + f[0]->width + f[1]->width + f[2]->width +
                       9.0 * (f[0]->degree + f[1]->degree + f[2]->degree);
  const double entry = 1.0 + kappa;
  return 8.0 * terms * std::numeric_limits<double>::epsilon() * 6.0 * entry * entry * entry;
}

struct Workspace {
  std::vector<double> block, t1, t2;
  TriPoly net[3];     // the displacement's Bezier net, per component
  TriPoly k[3][3];    // K[row][column], scaled form
  TriPoly p, q, r, scratch;
};

// D's Bezier net over the cell (up to a constant), per component: the offsets contracted axis by axis.
void displacement_net(const LatticeView& v, const AxisForm* const f[3], Workspace& ws, double& max_offset) {
  const auto res = v.lattice->resolution();
  const int w0 = f[0]->width, w1 = f[1]->width, w2 = f[2]->width;
  const int n0 = f[0]->degree + 1, n1 = f[1]->degree + 1, n2 = f[2]->degree + 1;
  ws.block.assign(std::size_t(3) * w0 * w1 * w2, 0.0);
  double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (int p = 0; p < w0; ++p)
    for (int q = 0; q < w1; ++q)
      for (int r = 0; r < w2; ++r) {
        const double* o = &v.offset[3 * ((std::size_t(f[0]->index[p]) * res[1] + f[1]->index[q]) * res[2] + f[2]->index[r])];
        for (int c = 0; c < 3; ++c) {
          ws.block[((std::size_t(p) * w1 + q) * w2 + r) * 3 + c] = o[c];
          lo[c] = std::min(lo[c], o[c]), hi[c] = std::max(hi[c], o[c]);
        }
      }
  // The weights sum to 1, so a constant taken off every offset leaves the derivatives as they
  // are: the offsets' midrange goes, and a translated cell has K = 0 exactly, with no rounding.
  const double mid[3] = {0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])};
  double largest = 0.0;
  for (std::size_t e = 0; e < ws.block.size(); e += 3)
    for (int c = 0; c < 3; ++c) {
      ws.block[e + c] -= mid[c];
      largest = std::max(largest, std::abs(ws.block[e + c]));
    }
  max_offset = largest;
  for (int c = 0; c < 3; ++c) ws.net[c].reset({f[0]->degree, f[1]->degree, f[2]->degree});
  if (f[0]->identity && f[1]->identity && f[2]->identity) {  // FFD, Bezier blocks, Blender's linear cells
    for (std::size_t e = 0, n = ws.block.size() / 3; e < n; ++e)
      for (int c = 0; c < 3; ++c) ws.net[c].c[e] = ws.block[3 * e + c];
    return;
  }
  // Along axis 2: t1[p][q][k][c], then axis 1: t2[p][j][k][c], then axis 0 into the nets.
  ws.t1.assign(std::size_t(3) * w0 * w1 * n2, 0.0);
  for (int p = 0; p < w0; ++p)
    for (int q = 0; q < w1; ++q)
      for (int k = 0; k < n2; ++k)
        for (int r = 0; r < w2; ++r) {
          const double b = f[2]->b[k * w2 + r];
          const double* src = &ws.block[((std::size_t(p) * w1 + q) * w2 + r) * 3];
          double* dst = &ws.t1[((std::size_t(p) * w1 + q) * n2 + k) * 3];
          for (int c = 0; c < 3; ++c) dst[c] += b * src[c];
        }
  ws.t2.assign(std::size_t(3) * w0 * n1 * n2, 0.0);
  for (int p = 0; p < w0; ++p)
    for (int j = 0; j < n1; ++j)
      for (int q = 0; q < w1; ++q) {
        const double b = f[1]->b[j * w1 + q];
        for (int k = 0; k < n2; ++k) {
          const double* src = &ws.t1[((std::size_t(p) * w1 + q) * n2 + k) * 3];
          double* dst = &ws.t2[((std::size_t(p) * n1 + j) * n2 + k) * 3];
          for (int c = 0; c < 3; ++c) dst[c] += b * src[c];
        }
      }
  for (int i = 0; i < n0; ++i)
    for (int p = 0; p < w0; ++p) {
      const double b = f[0]->b[i * w0 + p];
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

// p += 1 in the scaled form of p's degree: the product of the three binomials.
void add_scaled_one(TriPoly& p) {
  std::size_t e = 0;
  const auto& d = p.degree;
  for (int i = 0; i <= d[0]; ++i)
    for (int j = 0; j <= d[1]; ++j)
      for (int k = 0; k <= d[2]; ++k, ++e) p.c[e] += binomial(d[0], i) * binomial(d[1], j) * binomial(d[2], k);
}

// det(I + K) of a cell of degree 1 per axis (Blender's linear cells, FFD(1)): column a of
// M = I + K is bilinear in the other two coordinates, so det M = M0 . (M1 x M2) has degree
// (2, 2, 2), 27 coefficients; what the general path computes, with sizes known here.
void trilinear_det(const LatticeView& v, const Workspace& ws, const double factor[3], TriPoly& out) {
  // col[a][u][w]: column a at the Bezier index pair (u, w) over the other two axes, in order.
  Vec3 col[3][2][2];
  for (int a = 0; a < 3; ++a)
    for (int u = 0; u < 2; ++u)
      for (int w = 0; w < 2; ++w) {
        int lo[3], hi[3];
        const int b = a == 0 ? 1 : 0, c = a == 2 ? 1 : 2;
        lo[a] = 0, hi[a] = 1, lo[b] = hi[b] = u, lo[c] = hi[c] = w;
        Vec3 diff;
        for (int r = 0; r < 3; ++r)
          diff[r] = factor[a] * (ws.net[r].at(hi[0], hi[1], hi[2]) - ws.net[r].at(lo[0], lo[1], lo[2]));
        col[a][u][w] = v.to_box * diff;
        col[a][u][w][a] += 1.0;
      }
  // M1 (indices i, k) x M2 (indices i, j): degree (2, 1, 1) in (i, j, k).
  Vec3 cross[3][2][2];
  for (auto& x : cross)
    for (auto& y : x)
      for (auto& z : y) z.setZero();
  for (int i1 = 0; i1 < 2; ++i1)
    for (int k1 = 0; k1 < 2; ++k1)
      for (int i2 = 0; i2 < 2; ++i2)
        for (int j2 = 0; j2 < 2; ++j2) cross[i1 + i2][j2][k1] += col[1][i1][k1].cross(col[2][i2][j2]);
  // M0 (indices j, k) . cross: degree (2, 2, 2), then the binomials of degree 2 divided out.
  out.reset({2, 2, 2});
  for (int j0 = 0; j0 < 2; ++j0)
    for (int k0 = 0; k0 < 2; ++k0)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 2; ++j)
          for (int k = 0; k < 2; ++k) out.at(i, j0 + j, k0 + k) += col[0][j0][k0].dot(cross[i][j][k]);
  from_scaled(out);
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
  // Neighbouring cells share two of their three axis pieces: the last form per axis is kept.
  struct Cached {
    BasisKind kind;
    int count = -1, piece = 0;
    bool frozen = false;
    double lo = 0, hi = 0;
    AxisForm form;
  };
  thread_local Cached cache[3];
  const AxisForm* f[3];
  for (int a = 0; a < 3; ++a) {
    Cached& k = cache[a];
    if (k.count != axes[a].count || k.kind != axes[a].kind || k.piece != cell.piece[a] || k.frozen != cell.frozen[a] ||
        k.lo != cell.lo[a] || k.hi != cell.hi[a]) {
      k.form = axis_form(axes[a], cell, a);
      k.kind = axes[a].kind, k.count = axes[a].count, k.piece = cell.piece[a], k.frozen = cell.frozen[a];
      k.lo = cell.lo[a], k.hi = cell.hi[a];
    }
    f[a] = &k.form;
  }
  double max_offset = 0.0;
  displacement_net(v, f, ws, max_offset);
  const double a_norm = v.to_box.cwiseAbs().rowwise().sum().maxCoeff();
  const double beta = abs_row_sum(*f[0]) * abs_row_sum(*f[1]) * abs_row_sum(*f[2]);
  if (f[0]->degree == 1 && f[1]->degree == 1 && f[2]->degree == 1) {
    CellVolumeRatio out;
    double factor[3], kappa = 0.0;
    for (int a = 0; a < 3; ++a) {
      factor[a] = axes[a].scale() / (cell.hi[a] - cell.lo[a]);
      kappa = std::max(kappa, 2.0 * std::abs(factor[a]) * a_norm * beta * max_offset);
    }
    trilinear_det(v, ws, factor, out.coefficients);
    if (kappa > 0.0) out.rounding = rounding_allowance(kappa, 4, f);
    return out;
  }
  // M = I + K column by column; a column of a frozen axis is e_a (degree 0). In the scaled form
  // 1 has integer coefficients (binomials), so where K vanishes every product below is exact
  // and det M comes out 1 exactly.
  std::array<int, 3> result{0, 0, 0};
  double kappa = 0.0;  // a bound on |K|'s coefficients, for the rounding allowance
  auto& M = ws.k;
  for (int a = 0; a < 3; ++a) {
    if (f[a]->degree == 0) {
      for (int r = 0; r < 3; ++r) {
        if (r == a) M[r][a].reset({0, 0, 0}, 1.0);
        else M[r][a].clear();
      }
      continue;
    }
    const double factor = axes[a].scale() / (cell.hi[a] - cell.lo[a]);
    jacobian_column(v, ws, a, factor);
    add_scaled_one(M[a][a]);
    for (int b = 0; b < 3; ++b) result[b] += M[a][a].degree[b];
    kappa = std::max(kappa, 2.0 * f[a]->degree * std::abs(factor) * a_norm * beta * max_offset);
  }
  CellVolumeRatio out;
  TriPoly& acc = out.coefficients;
  if (v.at_rest) {  // beyond degree 8 or so the binomial products leave the integers doubles hold
    acc.reset(result, 1.0);
    return out;
  }
  acc.reset(result);
  // det M along column 0: sum_r (-1)^r M_r0 (the minor of the other rows in columns 1 and 2).
  TriPoly* minor[3] = {&ws.p, &ws.q, &ws.r};
  const int rows[3][2] = {{1, 2}, {0, 2}, {0, 1}};
  for (int r = 0; r < 3; ++r) {
    const int x = rows[r][0], y = rows[r][1];
    multiply_sum_scaled({{&M[x][1], &M[y][2], 1.0}, {&M[y][1], &M[x][2], -1.0}}, *minor[r]);
  }
  multiply_sum_scaled({{&M[0][0], minor[0], 1.0}, {&M[1][0], minor[1], -1.0}, {&M[2][0], minor[2], 1.0}}, ws.scratch);
  if (!ws.scratch.empty()) acc.c = ws.scratch.c;
  from_scaled(acc);
  if (kappa > 0.0) {
    std::size_t column = 0;
    for (int a = 0; a < 3; ++a) column = std::max(column, M[a][a].c.size());
    out.rounding = rounding_allowance(kappa, column, f);
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

}  // namespace deformkit
