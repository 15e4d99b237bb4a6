#include "cage/green_exterior.hpp"

#include "cage/cage_triangle.hpp"
#include "cage/dual3.hpp"
#include "cage/green_rows.hpp"

#include <Eigen/Dense>

#include <limits>
#include <vector>

namespace deformkit {
namespace {

using Vec3 = Eigen::Vector3d;

using Face = CageTriangle3;

// x - q for q the point of the closed triangle nearest to x (Ericson 2005, "Real-Time Collision
// Detection", §5.1.5: the Voronoi region of the closest feature). |x - q|^2 is C^1 in x with
// gradient 2 (x - q), whichever region x is in: the squared distance to a convex set.
Vec3 offset_from_triangle(const Vec3& x, const Face& t) {
  const Vec3 &a = t.p[0], &b = t.p[1], &c = t.p[2];
  const Vec3 ab = b - a, ac = c - a, ap = x - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return ap;
  const Vec3 bp = x - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return bp;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return ap - ab * (d1 / (d1 - d3));
  const Vec3 cp = x - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return cp;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return ap - ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return bp - (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = 1.0 / (va + vb + vc);
  return ap - ab * (vb * denom) - ac * (vc * denom);
}

// A value of x with its gradient (T = Dual3), or the value alone (T = double).
template <class T>
T with_gradient(double v, const Vec3& gradient);
template <>
double with_gradient(double v, const Vec3&) {
  return v;
}
template <>
Dual3 with_gradient(double v, const Vec3& gradient) {
  Dual3 r(v);
  for (int c = 0; c < 3; ++c) r.d[c] = gradient[c];
  return r;
}

inline void accumulate(double a, double* val, double*) { *val += a; }
inline void accumulate(const Dual3& a, double* val, double* grad) {
  *val += a.v;
  if (grad)
    for (int c = 0; c < 3; ++c) grad[c] += a.d[c];
}

// The unnormalised weight u_j = scale / d_j^2 with scale = the smallest d^2 (a constant of x, so it
// cancels in w_j = u_j / sum u and keeps the sum in [1, t] whatever the cage's size). With
// scale = 0, x is on faces: they share the weight.
template <class T>
T unnormalised_weight(double scale, const Vec3& offset) {
  const double d2 = offset.squaredNorm();
  if (scale == 0) return T(d2 == 0 ? 1.0 : 0.0);
  return T(scale) / with_gradient<T>(d2, 2.0 * offset);
}

// Face j's unit normal n and hat-function gradients g_k (in its plane), from the cage's tables when
// given, else computed by the same expressions (green_cage_tables), so both give the same bits.
// Returns false for a zero-area face.
bool face_frame(const Face& t, const GreenCageTables* tables, std::size_t j, Vec3& n, Vec3 g[3]) {
  if (tables) {
    const GreenCageTables::Triangle& tri = tables->triangles[j];
    if (tri.degenerate) return false;
    n = Vec3(tri.normal[0], tri.normal[1], tri.normal[2]);
    for (int l = 0; l < 3; ++l) g[l] = Vec3(tri.gradient[l][0], tri.gradient[l][1], tri.gradient[l][2]);
    return true;
  }
  const Vec3 nn = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]);
  const double twice_area = nn.norm();
  if (!(twice_area > 0)) return false;
  n = nn / twice_area;
  for (int l = 0; l < 3; ++l) g[l] = n.cross(t.p[(l + 2) % 3] - t.p[(l + 1) % 3]) / twice_area;
  return true;
}

// Face j's continuation through x (Lipman et al. 2008, §3.3): x = sum_k alpha_k v_jk + alpha_4 n_j,
// alpha_1..3 the barycentrics of x's foot point on the face's plane (alpha_k = -g_k . (p_{k+1} - x))
// and alpha_4 = n . (x - p_0) its height. Each is affine in x: its gradient is g_k, n.
template <class T>
void continuation(const Vec3& x, const Face& t, const Vec3& n, const Vec3 g[3], T alpha[4]) {
  for (int l = 0; l < 3; ++l) alpha[l] = with_gradient<T>(0.0 - g[l].dot(t.p[(l + 1) % 3] - x), g[l]);
  alpha[3] = with_gradient<T>(0.0 - n.dot(t.p[0] - x), n);
}

bool has_area(const Face& t, const GreenCageTables* tables, std::size_t j) {
  if (tables) return !tables->triangles[j].degenerate;
  return (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).norm() > 0;
}

template <class T>
std::size_t blend(const double xp[3], const TriangleCageView& cage, const GreenCageTables* tables, double vertex_weight,
                  double* phi, double* psi, double* dphi, double* dpsi) {
  const Vec3 x(xp[0], xp[1], xp[2]);
  // Each face's offset x - q_j, kept for the second pass (per thread, grown once).
  thread_local std::vector<Vec3> offsets;
  offsets.resize(cage.triangle_count);
  // Pass 1: the nearest face, the scale (its squared distance) and sum u, rescaled whenever the
  // scale drops (terms so far were scale_old / d^2).
  std::size_t nearest = 0;
  double scale = std::numeric_limits<double>::infinity();
  T total(0.0);
  for (std::size_t j = 0; j < cage.triangle_count; ++j) {
    const Face t = cage_triangle(cage, j);
    if (!has_area(t, tables, j)) continue;  // no measure, no continuation
    const Vec3 offset = offsets[j] = offset_from_triangle(x, t);
    const double d2 = offset.squaredNorm();
    if (d2 < scale) {
      total = total * T(d2 / scale);
      scale = d2;
      nearest = j;
    }
    total = total + unnormalised_weight<T>(scale, offset);
  }
  if (!(value_of(total) > 0)) return nearest;  // only zero-area faces
  // Pass 2: each face's continuation times w_j = u_j / sum u.
  const T inverse_total = T(1.0) / total;
  for (std::size_t j = 0; j < cage.triangle_count; ++j) {
    const Face t = cage_triangle(cage, j);
    Vec3 n, g[3];
    if (!face_frame(t, tables, j, n, g)) continue;
    T alpha[4];
    continuation(x, t, n, g, alpha);
    const T w = unnormalised_weight<T>(scale, offsets[j]) * inverse_total;
    accumulate(w * alpha[3], psi + j, dpsi ? dpsi + 3 * j : nullptr);
    const T vw = T(vertex_weight) * w;
    for (int l = 0; l < 3; ++l)
      accumulate(vw * alpha[l], phi + t.index[l], dphi ? dphi + 3 * static_cast<std::size_t>(t.index[l]) : nullptr);
  }
  return nearest;
}

}  // namespace

std::size_t add_exterior_continuation(const double x[3], const TriangleCageView& cage, const GreenCageTables* tables,
                                      double vertex_weight, double* phi, double* psi, double* dphi, double* dpsi) {
  if (dphi || dpsi) return blend<Dual3>(x, cage, tables, vertex_weight, phi, psi, dphi, dpsi);
  return blend<double>(x, cage, tables, vertex_weight, phi, psi, nullptr, nullptr);
}

}  // namespace deformkit
