// Compiled once per x86 target by Highway and dispatched at run time: no -march needed.
// The single-point code (green_coordinates.cpp) is the reference: every expression below is one
// of its expressions in the same order of operations, evaluated for a vector of points at once;
// only log and atan2 come from Highway's vector math (a few ulps).
#include "cage/green_rows.hpp"

#include <algorithm>
#include <cfloat>
#include <vector>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cage/green_rows.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep
#include "hwy/highway.h"
#include "hwy/contrib/math/math-inl.h"

HWY_BEFORE_NAMESPACE();
namespace deformkit {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using D = hn::ScalableTag<double>;
using V = hn::Vec<D>;
using M = hn::Mask<D>;

constexpr double kPi = 3.14159265358979323846;
constexpr double kInvFourPi = 1.0 / (4.0 * kPi);

// atan2 from atan on [0, 1]: the octant reduction keeps the argument in atan's accurate range
// and the result's sign follows y's sign bit, as std::atan2 does.
HWY_INLINE V Atan2(D d, V y, V x) {
  const V ax = hn::Abs(x), ay = hn::Abs(y);
  const V big = hn::Max(ax, ay), small = hn::Min(ax, ay);
  const V one = hn::Set(d, 1.0);
  V r = hn::Atan(d, hn::Div(small, hn::IfThenElse(hn::Eq(big, hn::Zero(d)), one, big)));
  r = hn::IfThenElse(hn::Gt(ay, ax), hn::Sub(hn::Set(d, 0.5 * kPi), r), r);
  r = hn::IfThenElse(hn::Lt(x, hn::Zero(d)), hn::Sub(hn::Set(d, kPi), r), r);
  return hn::CopySign(r, y);
}

// a.x * b.x + a.y * b.y + a.z * b.z with a constant, as dot(Vec3, V3) does.
HWY_INLINE V Dot(D d, const double* a, V x, V y, V z) {
  return hn::Add(hn::Add(hn::Mul(hn::Set(d, a[0]), x), hn::Mul(hn::Set(d, a[1]), y)), hn::Mul(hn::Set(d, a[2]), z));
}

// Per-lane scratch, structure of arrays: index (quantity * count + item) * lanes + lane.
struct Scratch {
  std::vector<double> vertex, edge, phi, psi;
};

enum VertexQuantity { kRx, kRy, kRz, kLen, kVertexQuantities };
enum EdgeQuantity { kWx, kWy, kWz, kSlo, kShi, kR0sq, kF, kEdgeQuantities };

void GreenRows(const double* points, size_t n, const TriangleCageView& cage, const GreenCageTables& tables,
               double* rows) {
  const D d;
  const size_t N = hn::Lanes(d);
  const size_t m = cage.point_count, t = cage.triangle_count, ne = tables.edges.size(), columns = m + t;
  thread_local Scratch s;
  s.vertex.resize(kVertexQuantities * m * N);
  s.edge.resize(kEdgeQuantities * ne * N);
  s.phi.resize(m * N);
  s.psi.resize(t * N);
  std::vector<double> lane_x(3 * N), lane_flag(N), lane_winding(N);
  auto vq = [&](int q, size_t j) { return s.vertex.data() + (q * m + j) * N; };
  auto eq = [&](int q, size_t e) { return s.edge.data() + (q * ne + e) * N; };
  const V zero = hn::Zero(d);

  for (size_t base = 0; base < n; base += N) {
    const size_t used = std::min(N, n - base);
    for (size_t k = 0; k < N; ++k)  // spare lanes repeat the last point
      for (int c = 0; c < 3; ++c) lane_x[c * N + k] = points[3 * (base + std::min(k, used - 1)) + c];
    const V x = hn::LoadU(d, lane_x.data()), y = hn::LoadU(d, lane_x.data() + N), z = hn::LoadU(d, lane_x.data() + 2 * N);
    // A lane that meets a guarded case (x on an edge's line, in a face's plane) is recomputed alone.
    M special = hn::Lt(zero, zero);

    for (size_t j = 0; j < m; ++j) {  // r = p_j - x and |r|
      const double* p = cage.points + 3 * j;
      const V rx = hn::Sub(hn::Set(d, p[0]), x), ry = hn::Sub(hn::Set(d, p[1]), y), rz = hn::Sub(hn::Set(d, p[2]), z);
      hn::StoreU(rx, d, vq(kRx, j));
      hn::StoreU(ry, d, vq(kRy, j));
      hn::StoreU(rz, d, vq(kRz, j));
      hn::StoreU(hn::Sqrt(hn::Add(hn::Add(hn::Mul(rx, rx), hn::Mul(ry, ry)), hn::Mul(rz, rz))), d, vq(kLen, j));
    }

    // Per edge: x's offset w from the edge's line, from the nearer end, and f = int_e 1/r (the
    // same for both triangles of the edge, as the single-point code computes it for either).
    for (size_t e = 0; e < ne; ++e) {
      const GreenCageTables::Edge& edge = tables.edges[e];
      if (!(edge.length > 0)) continue;  // only degenerate triangles meet it
      const V len_lo = hn::LoadU(d, vq(kLen, edge.lo)), len_hi = hn::LoadU(d, vq(kLen, edge.hi));
      const M from_lo = hn::Not(hn::Lt(len_hi, len_lo));
      const V ax = hn::IfThenElse(from_lo, hn::LoadU(d, vq(kRx, edge.lo)), hn::LoadU(d, vq(kRx, edge.hi)));
      const V ay = hn::IfThenElse(from_lo, hn::LoadU(d, vq(kRy, edge.lo)), hn::LoadU(d, vq(kRy, edge.hi)));
      const V az = hn::IfThenElse(from_lo, hn::LoadU(d, vq(kRz, edge.lo)), hn::LoadU(d, vq(kRz, edge.hi)));
      const V s_near = Dot(d, edge.direction, ax, ay, az);
      const V length = hn::Set(d, edge.length);
      const V s_lo = hn::IfThenElse(from_lo, s_near, hn::Sub(s_near, length));
      const V s_hi = hn::IfThenElse(from_lo, hn::Add(s_near, length), s_near);
      const V wx = hn::Sub(ax, hn::Mul(hn::Set(d, edge.direction[0]), s_near));
      const V wy = hn::Sub(ay, hn::Mul(hn::Set(d, edge.direction[1]), s_near));
      const V wz = hn::Sub(az, hn::Mul(hn::Set(d, edge.direction[2]), s_near));
      const V r0sq = hn::Add(hn::Add(hn::Mul(wx, wx), hn::Mul(wy, wy)), hn::Mul(wz, wz));
      special = hn::Or(special, hn::Not(hn::Gt(r0sq, hn::Set(d, DBL_MIN))));
      const M beyond_lo = hn::Ge(s_lo, zero), before_hi = hn::Le(s_hi, zero);
      const V a = hn::Add(len_hi, s_hi), b = hn::Sub(len_lo, s_lo);
      const V num = hn::IfThenElse(beyond_lo, a, hn::IfThenElse(before_hi, b, hn::Mul(a, b)));
      const V den = hn::IfThenElse(beyond_lo, hn::Add(len_lo, s_lo), hn::IfThenElse(before_hi, hn::Sub(len_hi, s_hi), r0sq));
      hn::StoreU(wx, d, eq(kWx, e));
      hn::StoreU(wy, d, eq(kWy, e));
      hn::StoreU(wz, d, eq(kWz, e));
      hn::StoreU(s_lo, d, eq(kSlo, e));
      hn::StoreU(s_hi, d, eq(kShi, e));
      hn::StoreU(r0sq, d, eq(kR0sq, e));
      hn::StoreU(hn::Log(d, hn::Div(num, den)), d, eq(kF, e));
    }

    std::fill(s.phi.begin(), s.phi.end(), 0.0);
    std::fill(s.psi.begin(), s.psi.end(), 0.0);
    V solid_angle = zero;
    for (size_t j = 0; j < t; ++j) {  // triangle_share() per triangle, in the same order
      const GreenCageTables::Triangle& tri = tables.triangles[j];
      if (tri.degenerate) continue;
      const int* v = tri.vertex;
      V rx[3], ry[3], rz[3];
      for (int k = 0; k < 3; ++k) {
        rx[k] = hn::LoadU(d, vq(kRx, v[k]));
        ry[k] = hn::LoadU(d, vq(kRy, v[k]));
        rz[k] = hn::LoadU(d, vq(kRz, v[k]));
      }
      const V h = Dot(d, tri.normal, rx[0], ry[0], rz[0]);
      special = hn::Or(special, hn::Eq(h, zero));
      const V side = hn::IfThenElse(hn::Lt(h, zero), hn::Set(d, -1.0), hn::Set(d, 1.0));
      V foot[3];
      for (int l = 0; l < 3; ++l) {
        const int l1 = (l + 1) % 3;
        foot[l] = hn::Sub(zero, Dot(d, tri.gradient[l], rx[l1], ry[l1], rz[l1]));
      }
      V sum_tf = zero, sum_hb = zero, sum_b = zero, mfx = zero, mfy = zero, mfz = zero;
      for (int k = 0; k < 3; ++k) {
        const size_t e = size_t(tri.edge[k]);
        const GreenCageTables::Edge& edge = tables.edges[e];
        const V wx = hn::LoadU(d, eq(kWx, e)), wy = hn::LoadU(d, eq(kWy, e)), wz = hn::LoadU(d, eq(kWz, e));
        const V s_lo = hn::LoadU(d, eq(kSlo, e)), s_hi = hn::LoadU(d, eq(kShi, e));
        const V r0sq = hn::LoadU(d, eq(kR0sq, e)), f = hn::LoadU(d, eq(kF, e));
        const V len_lo = hn::LoadU(d, vq(kLen, edge.lo)), len_hi = hn::LoadU(d, vq(kLen, edge.hi));
        const V t0 = Dot(d, tri.edge_normal[k], wx, wy, wz);
        const V h_abs = hn::Abs(Dot(d, tri.normal, wx, wy, wz));
        const V y_hi = hn::Mul(t0, s_hi), x_hi = hn::Add(r0sq, hn::Mul(h_abs, len_hi));
        const V y_lo = hn::Mul(t0, s_lo), x_lo = hn::Add(r0sq, hn::Mul(h_abs, len_lo));
        const V beta = Atan2(d, hn::Sub(hn::Mul(y_hi, x_lo), hn::Mul(y_lo, x_hi)),
                             hn::Add(hn::Mul(x_hi, x_lo), hn::Mul(y_hi, y_lo)));
        sum_tf = hn::Add(sum_tf, hn::Mul(t0, f));
        sum_hb = hn::Add(sum_hb, hn::Mul(h_abs, beta));
        sum_b = hn::Add(sum_b, beta);
        mfx = hn::Add(mfx, hn::Mul(hn::Set(d, tri.edge_normal[k][0]), f));
        mfy = hn::Add(mfy, hn::Mul(hn::Set(d, tri.edge_normal[k][1]), f));
        mfz = hn::Add(mfz, hn::Mul(hn::Set(d, tri.edge_normal[k][2]), f));
      }
      const V omega = hn::Mul(side, sum_b);
      const V inv = hn::Set(d, kInvFourPi);
      solid_angle = hn::Add(solid_angle, omega);
      double* psi = s.psi.data() + j * N;
      hn::StoreU(hn::Add(hn::LoadU(d, psi), hn::Mul(hn::Sub(sum_tf, sum_hb), inv)), d, psi);
      for (int l = 0; l < 3; ++l) {
        const V phi = hn::Mul(hn::Sub(hn::Mul(foot[l], omega), hn::Mul(h, Dot(d, tri.gradient[l], mfx, mfy, mfz))), inv);
        double* acc = s.phi.data() + size_t(v[l]) * N;
        hn::StoreU(hn::Add(hn::LoadU(d, acc), phi), d, acc);
      }
    }

    hn::StoreU(hn::VecFromMask(d, special), d, lane_flag.data());
    hn::StoreU(hn::Div(solid_angle, hn::Set(d, 4.0 * kPi)), d, lane_winding.data());
    for (size_t k = 0; k < used; ++k) {
      double* row = rows + (base + k) * columns;
      const double* xk = points + 3 * (base + k);
      if (lane_flag[k] != 0.0) {
        green_coordinates(xk, cage, row, row + m, nullptr, nullptr, &tables);
        continue;
      }
      for (size_t j = 0; j < m; ++j) row[j] = s.phi[j * N + k];
      for (size_t j = 0; j < t; ++j) row[m + j] = s.psi[j * N + k];
      green_extension(xk, cage, lane_winding[k], row, row + m, &tables);
    }
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace deformkit
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace deformkit {

HWY_EXPORT(GreenRows);

void green_coordinate_rows(const double* points, std::size_t n, const TriangleCageView& cage,
                           const GreenCageTables& tables, double* rows) {
  HWY_DYNAMIC_DISPATCH(GreenRows)(points, n, cage, tables, rows);
}

}  // namespace deformkit
#endif  // HWY_ONCE
