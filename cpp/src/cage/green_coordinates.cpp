#include "cage/green_coordinates.hpp"

#include "cage/cage_triangle.hpp"
#include "cage/green_exterior.hpp"
#include "cage/green_rows.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <limits>
#include <map>
#include <utility>

namespace deformkit {
namespace {

using Vec3 = Eigen::Vector3d;

constexpr double kFourPi = 4.0 * 3.14159265358979323846;

// Forward-mode derivative with respect to the point x: the gradients are the same closed form
// differentiated exactly, so they hold as near the cage as the values do (no step size).
struct Dual {
  double v = 0;
  double d[3] = {0, 0, 0};
};

inline double value(double a) { return a; }
inline double value(const Dual& a) { return a.v; }

inline Dual operator+(const Dual& a, const Dual& b) {
  return {a.v + b.v, {a.d[0] + b.d[0], a.d[1] + b.d[1], a.d[2] + b.d[2]}};
}
inline Dual operator-(const Dual& a, const Dual& b) {
  return {a.v - b.v, {a.d[0] - b.d[0], a.d[1] - b.d[1], a.d[2] - b.d[2]}};
}
inline Dual operator*(const Dual& a, const Dual& b) {
  return {a.v * b.v,
          {a.d[0] * b.v + a.v * b.d[0], a.d[1] * b.v + a.v * b.d[1], a.d[2] * b.v + a.v * b.d[2]}};
}
inline Dual operator/(const Dual& a, const Dual& b) {
  const double q = a.v / b.v;
  return {q, {(a.d[0] - q * b.d[0]) / b.v, (a.d[1] - q * b.d[1]) / b.v, (a.d[2] - q * b.d[2]) / b.v}};
}
inline Dual operator+(const Dual& a, double b) { return {a.v + b, {a.d[0], a.d[1], a.d[2]}}; }
inline Dual operator-(const Dual& a, double b) { return a + (-b); }
inline Dual operator-(double a, const Dual& b) { return {a - b.v, {-b.d[0], -b.d[1], -b.d[2]}}; }
inline Dual operator*(double a, const Dual& b) { return {a * b.v, {a * b.d[0], a * b.d[1], a * b.d[2]}}; }
inline Dual operator*(const Dual& a, double b) { return b * a; }

// The chain rule with f(v) and f'(v); a zero derivative where f' is infinite keeps the guarded
// points (x on a cage vertex or edge) finite, as their values are.
inline Dual chain(const Dual& a, double f, double df) {
  if (!std::isfinite(df)) df = 0;
  return {f, {df * a.d[0], df * a.d[1], df * a.d[2]}};
}
inline Dual sqrt(const Dual& a) {
  const double s = std::sqrt(a.v);
  return chain(a, s, s > 0 ? 0.5 / s : 0.0);
}
inline Dual log(const Dual& a) { return chain(a, std::log(a.v), 1.0 / a.v); }
inline Dual atan2(const Dual& y, const Dual& x) {
  const double r2 = x.v * x.v + y.v * y.v;
  Dual out{std::atan2(y.v, x.v), {0, 0, 0}};
  if (r2 > 0)
    for (int c = 0; c < 3; ++c) out.d[c] = (x.v * y.d[c] - y.v * x.d[c]) / r2;
  return out;
}
// The value set to 0, the derivative kept.
inline Dual without_value(const Dual& a) { return {0.0, {a.d[0], a.d[1], a.d[2]}}; }
inline double without_value(double) { return 0.0; }
inline double sqrt(double a) { return std::sqrt(a); }
inline double log(double a) { return std::log(a); }
inline double atan2(double y, double x) { return std::atan2(y, x); }

// A vector whose components depend on x (T = Dual) or not (T = double).
template <class T>
struct V3 {
  T x, y, z;
};
template <class T>
V3<T> minus(const Vec3& p, const V3<T>& q) {
  return {p.x() - q.x, p.y() - q.y, p.z() - q.z};
}
template <class T>
T dot(const Vec3& a, const V3<T>& b) {
  return a.x() * b.x + a.y() * b.y + a.z() * b.z;
}
template <class T>
T dot(const V3<T>& a, const V3<T>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

template <class T>
V3<T> point_variable(const double x[3]);
template <>
V3<double> point_variable(const double x[3]) {
  return {x[0], x[1], x[2]};
}
template <>
V3<Dual> point_variable(const double x[3]) {
  return {{x[0], {1, 0, 0}}, {x[1], {0, 1, 0}}, {x[2], {0, 0, 1}}};
}

inline void accumulate(double a, double* val, double*) { *val += a; }
inline void accumulate(const Dual& a, double* val, double* grad) {
  *val += a.v;
  grad[0] += a.d[0];
  grad[1] += a.d[1];
  grad[2] += a.d[2];
}

using Triangle = CageTriangle3;

inline Triangle triangle(const TriangleCageView& cage, std::size_t j) { return cage_triangle(cage, j); }

// (s_hi/R_hi - s_lo/R_lo) / t0 for x in a triangle's plane (R^2 = s^2 + t0^2): with both ends on one
// side of x's foot, s/R = sign(s) / sqrt(1 + t0^2/s^2) and the difference is written without
// cancellation, so it stays right (-> 0 like t0) as x nears the edge's line.
double plane_slope_term(double t0, double s_lo, double s_hi, double r_lo, double r_hi) {
  if (s_lo * s_hi > 0) {
    const double a = r_hi / std::abs(s_hi), b = r_lo / std::abs(s_lo);
    return (s_hi > 0 ? 1.0 : -1.0) * t0 * (1.0 / (s_lo * s_lo) - 1.0 / (s_hi * s_hi)) / (a * b * (a + b));
  }
  return (s_hi / r_hi - s_lo / r_lo) / t0;
}

template <class T>
struct TriangleShare {
  T phi[3];
  T psi;
  T solid_angle;
  T foot_barycentric[3];
  T height;
};

// One triangle's share of the Green integrals at x: the double layer with the hat functions (phi),
// the single layer (psi), the signed solid angle, and the barycentric coordinates of x's foot point
// with its height below the plane (the exterior extension's alpha_1..3 and -alpha_4);
// docs/math/green_coordinates.md, "Per-triangle closed form".
template <class T>
bool triangle_share(const V3<T>& x, const Triangle& t, TriangleShare<T>& out) {
  const Vec3 nn = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]);
  const double twice_area = nn.norm();
  if (!(twice_area > 0)) return false;  // a degenerate triangle carries no measure
  const Vec3 n = nn / twice_area;
  const V3<T> r[3] = {minus(t.p[0], x), minus(t.p[1], x), minus(t.p[2], x)};
  const T len[3] = {sqrt(dot(r[0], r[0])), sqrt(dot(r[1], r[1])), sqrt(dot(r[2], r[2]))};
  // h = n.(xi - x) on the triangle: positive when x is behind it (inside an outward cage).
  const T h = dot(n, r[0]);
  const bool in_plane = value(h) == 0;
  const double side = value(h) < 0 ? -1.0 : 1.0;
  // The hat function of vertex l is Gamma_l(xi) = Gamma_l(foot) + g_l.(xi - foot) on the plane.
  Vec3 g[3];
  for (int l = 0; l < 3; ++l) {
    g[l] = n.cross(t.p[(l + 2) % 3] - t.p[(l + 1) % 3]) / twice_area;
    out.foot_barycentric[l] = 0.0 - dot(g[l], r[(l + 1) % 3]);
  }

  // Per edge (Graglia 1993, IEEE Trans. Antennas Propag. 41(10)): the line integral f_e = int_e 1/r and
  // the edge's share beta_e of the solid angle |Omega| = sum_e beta_e, from x's offset w_e from the
  // edge's line. w_e, f_e and beta_e are computed the same way whichever triangle asks (direction
  // from the lower vertex index, offset from the nearer end), so the two triangles of an edge see the
  // same w_e and their solid angles sum to the winding number to rounding also 1e-12 from the edge
  // (docs/math/green_coordinates.md, "Near edges").
  T sum_tf{}, sum_hb{}, sum_b{};
  double plane_slope = 0;
  V3<T> sum_mf{T{}, T{}, T{}};
  for (int k = 0; k < 3; ++k) {
    const int k1 = (k + 1) % 3;
    const bool forward = t.index[k] < t.index[k1];
    const int lo = forward ? k : k1, hi = forward ? k1 : k;
    const Vec3 edge = t.p[hi] - t.p[lo];
    const double length = edge.norm();
    const Vec3 e = edge / length;
    const Vec3 m = (forward ? e : Vec3(-e)).cross(n);  // outward in the plane (counter-clockwise triangle)
    // From the end nearer to x (ties: the lower index), w_e is a difference of small numbers near a vertex.
    const bool from_lo = !(value(len[hi]) < value(len[lo]));
    const V3<T>& a = r[from_lo ? lo : hi];
    const T s_near = dot(e, a);
    const T s_lo = from_lo ? s_near : s_near - length;
    const T s_hi = from_lo ? s_near + length : s_near;
    const V3<T> w{a.x - e.x() * s_near, a.y - e.y() * s_near, a.z - e.z() * s_near};
    const T r0_squared = dot(w, w);
    // x on the edge itself: f_e diverges only where its weights t0 and h are both 0, and beta_e is 0
    // (the paper's GCTriInt guard, docs/math/green_coordinates.md, "Guards"). On the edge's line
    // beyond its ends f_e is finite and its gradient terms (f_e grad t0, f_e grad h) count.
    const bool on_line = !(value(r0_squared) > std::numeric_limits<double>::min());
    if (on_line && value(s_lo) <= 0 && value(s_hi) >= 0) continue;
    const T t0 = dot(m, w);  // in-plane distance of x's foot point inside the edge
    const T h_e = dot(n, w);
    const T h_abs = in_plane ? T{} : value(h_e) < 0 ? 0.0 - h_e : h_e;
    const T f = value(s_lo) >= 0   ? log((len[hi] + s_hi) / (len[lo] + s_lo))
                : value(s_hi) <= 0 ? log((len[lo] - s_lo) / (len[hi] - s_hi))
                                   : log((len[hi] + s_hi) * (len[lo] - s_lo) / r0_squared);
    // beta_e = atan(y_hi / x_hi) - atan(y_lo / x_lo) with x > 0: both in (-pi/2, pi/2), so their
    // difference is one atan2 of the difference's sine and cosine (scaled by x_hi x_lo / ...).
    const T y_hi = t0 * s_hi, x_hi = r0_squared + h_abs * len[hi];
    const T y_lo = t0 * s_lo, x_lo = r0_squared + h_abs * len[lo];
    const T beta = atan2(y_hi * x_lo - y_lo * x_hi, x_hi * x_lo + y_hi * y_lo);
    // In the plane Omega = 0 with slope dOmega/dh = int_t 1/rho^3 = -sum_e (s_hi/R_hi - s_lo/R_lo) / t0_e
    // (polar coordinates about x; an edge whose line holds x adds 0).
    if (in_plane && !on_line)
      plane_slope -= plane_slope_term(value(t0), value(s_lo), value(s_hi), value(len[lo]), value(len[hi]));
    sum_tf = sum_tf + t0 * f;
    sum_hb = sum_hb + h_abs * beta;
    sum_b = sum_b + beta;
    sum_mf.x = sum_mf.x + m.x() * f;
    sum_mf.y = sum_mf.y + m.y() * f;
    sum_mf.z = sum_mf.z + m.z() * f;
  }
  // The signed solid angle int_t h / r^3. For x on the closed triangle itself (in its plane, foot
  // barycentrics >= 0) the principal value 0: n.(xi - x) = 0 on the whole face
  // (docs/math/green_coordinates.md, "On the cage").
  const bool on_triangle = in_plane && value(out.foot_barycentric[0]) >= 0 && value(out.foot_barycentric[1]) >= 0 &&
                           value(out.foot_barycentric[2]) >= 0;
  const T omega = on_triangle ? T{} : in_plane ? plane_slope * without_value(h) : side * sum_b;
  // int_t 1/r = sum_e (t0_e f_e - |h| beta_e).
  out.psi = (sum_tf - sum_hb) * (1.0 / kFourPi);
  out.solid_angle = omega;
  out.height = h;
  // int_t (xi - x)_tangential / r^3 = -sum_e m_e f_e (the divergence theorem in the plane).
  for (int l = 0; l < 3; ++l)
    out.phi[l] = (out.foot_barycentric[l] * omega - h * dot(g[l], sum_mf)) * (1.0 / kFourPi);
  return true;
}

void clear(double* a, std::size_t n) {
  if (a)
    for (std::size_t i = 0; i < n; ++i) a[i] = 0;
}

template <class T>
double integrals(const double x[3], const TriangleCageView& cage, double* phi, double* psi, double* dphi,
                 double* dpsi) {
  clear(phi, cage.point_count);
  clear(psi, cage.triangle_count);
  clear(dphi, 3 * cage.point_count);
  clear(dpsi, 3 * cage.triangle_count);
  const V3<T> xv = point_variable<T>(x);
  double solid_angle = 0;
  TriangleShare<T> share;
  for (std::size_t j = 0; j < cage.triangle_count; ++j) {
    const Triangle t = triangle(cage, j);
    if (!triangle_share(xv, t, share)) continue;
    solid_angle += value(share.solid_angle);
    accumulate(share.psi, psi + j, dpsi ? dpsi + 3 * j : nullptr);
    for (int l = 0; l < 3; ++l)
      accumulate(share.phi[l], phi + t.index[l], dphi ? dphi + 3 * static_cast<std::size_t>(t.index[l]) : nullptr);
  }
  return solid_angle / kFourPi;
}

// Off the surface the winding number is an integer to rounding (a sum of t solid angles, each
// to ~1e-16); a fractional one means x is on the cage (docs/math/green_coordinates.md, "On the cage").
constexpr double kWindingTolerance = 1e-9;

}  // namespace

void green_integrals(const double x[3], const TriangleCageView& cage, double* phi, double* psi, double* dphi,
                     double* dpsi) {
  if (dphi || dpsi)
    integrals<Dual>(x, cage, phi, psi, dphi, dpsi);
  else
    integrals<double>(x, cage, phi, psi, nullptr, nullptr);
}

namespace {

GreenSide extension(const double x[3], const TriangleCageView& cage, const GreenCageTables* tables, double winding,
                    double* phi, double* psi, double* dphi, double* dpsi) {
  GreenSide side;
  side.winding = winding;
  if (side.winding >= 1.0 - kWindingTolerance || cage.triangle_count == 0) return side;
  side.outside = side.winding <= kWindingTolerance;
  side.on_surface = !side.outside;
  // On the surface the raw double layer is its principal value; the inside limit adds (1 - winding)
  // times the hat functions at x, those of any triangle through x (the faces at distance 0, which
  // share the blend's weight). Outside the weight is 1 - 0, the continuations' alphas; 1 - winding
  // there also absorbs the winding number's rounding.
  side.face = add_exterior_continuation(x, cage, tables, 1.0 - side.winding, phi, psi, dphi, dpsi);
  return side;
}

}  // namespace

GreenSide green_coordinates(const double x[3], const TriangleCageView& cage, double* phi, double* psi, double* dphi,
                            double* dpsi, const GreenCageTables* tables) {
  const double winding = dphi || dpsi ? integrals<Dual>(x, cage, phi, psi, dphi, dpsi)
                                      : integrals<double>(x, cage, phi, psi, nullptr, nullptr);
  return extension(x, cage, tables, winding, phi, psi, dphi, dpsi);
}

GreenSide green_extension(const double x[3], const TriangleCageView& cage, double winding, double* phi,
                          double* psi, const GreenCageTables* tables) {
  return extension(x, cage, tables, winding, phi, psi, nullptr, nullptr);
}

GreenCageTables green_cage_tables(const TriangleCageView& cage) {
  GreenCageTables tables;
  std::map<std::pair<int, int>, int> edge_ids;
  for (std::size_t j = 0; j < cage.triangle_count; ++j) {
    const Triangle t = triangle(cage, j);
    GreenCageTables::Triangle out;
    // As triangle_share() computes them, so that both paths multiply by the same constants.
    const Vec3 nn = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]);
    const double twice_area = nn.norm();
    out.degenerate = !(twice_area > 0);
    const Vec3 n = out.degenerate ? Vec3::Zero() : Vec3(nn / twice_area);
    for (int k = 0; k < 3; ++k) {
      out.vertex[k] = t.index[k];
      out.normal[k] = n[k];
      const Vec3 g = n.cross(t.p[(k + 2) % 3] - t.p[(k + 1) % 3]) / twice_area;
      const int k1 = (k + 1) % 3;
      const bool forward = t.index[k] < t.index[k1];
      const int lo = forward ? k : k1, hi = forward ? k1 : k;
      const Vec3 edge = t.p[hi] - t.p[lo];
      const double length = edge.norm();
      const Vec3 e = edge / length;
      const Vec3 m = (forward ? e : Vec3(-e)).cross(n);
      for (int c = 0; c < 3; ++c) {
        out.gradient[k][c] = g[c];
        out.edge_normal[k][c] = m[c];
      }
      const auto key = std::make_pair(t.index[lo], t.index[hi]);
      auto found = edge_ids.find(key);
      if (found == edge_ids.end()) {
        GreenCageTables::Edge ed;
        ed.lo = key.first;
        ed.hi = key.second;
        for (int c = 0; c < 3; ++c) ed.direction[c] = e[c];
        ed.length = length;
        found = edge_ids.emplace(key, int(tables.edges.size())).first;
        tables.edges.push_back(ed);
      }
      out.edge[k] = found->second;
    }
    tables.triangles.push_back(out);
  }
  return tables;
}

void green_stretch_factors(const double* rest_points, const double* deformed_points, const int* triangles,
                           std::size_t triangle_count, double* out) {
  auto point = [](const double* p, int i) { return Vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]); };
  for (std::size_t j = 0; j < triangle_count; ++j) {
    const int* v = triangles + 3 * j;
    const Vec3 u = point(rest_points, v[1]) - point(rest_points, v[0]);
    const Vec3 w = point(rest_points, v[2]) - point(rest_points, v[0]);
    const Vec3 ud = point(deformed_points, v[1]) - point(deformed_points, v[0]);
    const Vec3 wd = point(deformed_points, v[2]) - point(deformed_points, v[0]);
    // Lipman et al. 2008: s = sqrt(|u'|^2|v|^2 - 2(u'.v')(u.v) + |v'|^2|u|^2) / (sqrt(8) area), the
    // edge-length form of the 2D conformal factor (docs/math/green_coordinates.md, "Stretch factor").
    const double numerator =
        ud.squaredNorm() * w.squaredNorm() - 2.0 * ud.dot(wd) * u.dot(w) + wd.squaredNorm() * u.squaredNorm();
    const double area = 0.5 * u.cross(w).norm();
    out[j] = std::sqrt(std::max(0.0, numerator)) / (std::sqrt(8.0) * area);
  }
}

void green_scaled_normals(const double* deformed_points, const int* triangles, std::size_t triangle_count,
                          const double* stretch, double* out) {
  auto point = [&](int i) {
    return Vec3(deformed_points[3 * i], deformed_points[3 * i + 1], deformed_points[3 * i + 2]);
  };
  for (std::size_t j = 0; j < triangle_count; ++j) {
    const int* v = triangles + 3 * j;
    const Vec3 nn = (point(v[1]) - point(v[0])).cross(point(v[2]) - point(v[0]));
    const double length = nn.norm();
    const Vec3 n = length > 0 ? Vec3(nn / length) : Vec3::Zero();
    const double s = stretch ? stretch[j] : 1.0;
    for (int c = 0; c < 3; ++c) out[3 * j + c] = s * n[c];
  }
}

namespace {

// F += weight * control and, with a gradient, J += control gradient^T (one column of the sum).
struct DeformedPoint {
  double f[3] = {0, 0, 0};
  double jacobian[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  void add(const double* control, double weight, const double* gradient) {
    for (int r = 0; r < 3; ++r) {
      f[r] += weight * control[r];
      if (gradient)
        for (int c = 0; c < 3; ++c) jacobian[3 * r + c] += control[r] * gradient[c];
    }
  }
  void write(double out[3], double* jacobian_out) const {
    for (int r = 0; r < 3; ++r) out[r] = f[r];
    if (jacobian_out)
      for (int k = 0; k < 9; ++k) jacobian_out[k] = jacobian[k];
  }
};

}  // namespace

void green_deform_point(const double* phi, const double* psi, const double* dphi, const double* dpsi,
                        const double* deformed_points, std::size_t point_count, const double* scaled_normals,
                        std::size_t triangle_count, double out[3], double* jacobian) {
  const bool want_jacobian = jacobian && dphi && dpsi;
  DeformedPoint p;
  for (std::size_t i = 0; i < point_count; ++i)
    p.add(deformed_points + 3 * i, phi[i], want_jacobian ? dphi + 3 * i : nullptr);
  for (std::size_t j = 0; j < triangle_count; ++j)
    p.add(scaled_normals + 3 * j, psi[j], want_jacobian ? dpsi + 3 * j : nullptr);
  p.write(out, want_jacobian ? jacobian : nullptr);
}

void green_deform_point(const double* phi, const double* psi, const double* dphi, const double* dpsi,
                        const TriangleCageView& deformed, const double* stretch, double out[3], double* jacobian) {
  const bool want_jacobian = jacobian && dphi && dpsi;
  DeformedPoint p;
  for (std::size_t i = 0; i < deformed.point_count; ++i)
    p.add(deformed.points + 3 * i, phi[i], want_jacobian ? dphi + 3 * i : nullptr);
  for (std::size_t j = 0; j < deformed.triangle_count; ++j) {
    double scaled_normal[3];
    green_scaled_normals(deformed.points, deformed.triangles + 3 * j, 1, stretch ? stretch + j : nullptr,
                         scaled_normal);
    p.add(scaled_normal, psi[j], want_jacobian ? dpsi + 3 * j : nullptr);
  }
  p.write(out, want_jacobian ? jacobian : nullptr);
}

}  // namespace deformkit
