#include "deformkit/cage/mean_value_cage.hpp"

#include "cage/dual3.hpp"
#include "cage/mean_value_rows.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace deformkit {

namespace {

// Closer than this (relative to the cage's length scale) to a vertex or a face is on it: a few
// ulps of the coordinates, so that points computed on a face are recognised there.
constexpr double kOnCage = 1e-14;
// A triangle whose plane passes this close to x (relative to x's distance to the triangle),
// with x's projection outside it, is skipped: its contribution is O(h / rho) there while the
// determinant's cancellation costs O(eps rho / h); both stay below 1e-8 (docs/math/cage.md,
// "Accuracy near the cage"). The distance to the nearest vertex, an upper bound of rho, gates the
// check, so a point away from every plane pays nothing for it.
constexpr double kNearPlane = 1e-8;
// A projection this far outside a triangle (in barycentric terms) still lies on it.
constexpr double kOnEdge = 1e-12;

using std::asin;
using std::sqrt;

template <class T>
struct V {
  T x, y, z;
};
template <class T>
V<T> sub(const V<T>& a, const V<T>& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class T>
T dot(const V<T>& a, const V<T>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <class T>
V<T> cross(const V<T>& a, const V<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T>
V<T> scaled(const V<T>& a, const T& s) {
  return {a.x * s, a.y * s, a.z * s};
}
template <class T>
T norm(const V<T>& a) {
  return sqrt(dot(a, a));
}

// Distance from x to the triangle's edges, given e_k = p_k - x: where x's projection falls
// outside the triangle, its distance to the triangle.
double distance_to_edges(const Vec3 (&e)[3]) {
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    const Vec3 a = e[k], ab = e[(k + 1) % 3] - e[k];
    const double t = std::clamp(-a.dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (a + t * ab).norm());
  }
  return best;
}

template <class T>
std::vector<T>& scratch(std::size_t size) {
  thread_local std::vector<T> s;
  s.resize(size);
  return s;
}

}  // namespace

MeanValueCage::MeanValueCage(CageMesh cage) : CageDeformer(std::move(cage)) {
  const std::vector<double>& p = rest_cage_points();
  for (const CageTriangle& t : this->cage().triangles()) {
    const Vec3 a(p[3 * t[0]], p[3 * t[0] + 1], p[3 * t[0] + 2]), b(p[3 * t[1]], p[3 * t[1] + 1], p[3 * t[1] + 2]),
        c(p[3 * t[2]], p[3 * t[2] + 1], p[3 * t[2] + 2]);
    const Vec3 n = (b - a).cross(c - a);
    area2_.push_back(n.norm());
    normal_.push_back(n / n.norm());
    flat_triangles_.insert(flat_triangles_.end(), t.begin(), t.end());
    for (int a = 0; a < 3; ++a) flat_normals_.push_back(normal_.back()[a]);
  }
  on_cage_ = kOnCage * this->cage().length_scale();
}

void MeanValueCage::control_values(double* out) const { std::copy(cage_points().begin(), cage_points().end(), out); }

// The weights at x (T = double, or Dual3 for their gradients too), normalised to sum to 1.
template <class T>
void MeanValueCage::weights(const T* x, T* w) const {
  const std::vector<double>& p = rest_cage_points();
  const std::size_t m = vertex_count();
  std::vector<T>& e = scratch<T>(4 * m);  // e_j = p_j - x, then d_j = |e_j|
  T* d = e.data() + 3 * m;
  for (std::size_t j = 0; j < m; ++j) {
    for (int a = 0; a < 3; ++a) e[3 * j + a] = T(p[3 * j + a]) - x[a];
    d[j] = sqrt(e[3 * j] * e[3 * j] + e[3 * j + 1] * e[3 * j + 1] + e[3 * j + 2] * e[3 * j + 2]);
  }
  std::fill(w, w + m, T(0.0));
  for (std::size_t j = 0; j < m; ++j)
    if (value_of(d[j]) <= on_cage_) {  // on a vertex: that vertex
      w[j] = T(1.0);
      return;
    }
  const auto& triangles = cage().triangles();
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const int* v = triangles[t].data();
    const V<T> ev[3] = {{e[3 * v[0]], e[3 * v[0] + 1], e[3 * v[0] + 2]},
                        {e[3 * v[1]], e[3 * v[1] + 1], e[3 * v[1] + 2]},
                        {e[3 * v[2]], e[3 * v[2] + 1], e[3 * v[2] + 2]}};
    const Vec3& nt = normal_[t];
    const V<T> n{T(nt.x()), T(nt.y()), T(nt.z())};
    const T h = dot(n, ev[0]);  // signed distance to the triangle's plane (positive inside)
    const double dmin = std::min({value_of(d[v[0]]), value_of(d[v[1]]), value_of(d[v[2]])});
    if (std::abs(value_of(h)) <= std::max(on_cage_, kNearPlane * dmin)) {
      // Barycentric coordinates of x's projection: the areas of (x, p_k+1, p_k+2) over the whole.
      T lambda[3];
      bool inside = true;
      for (int k = 0; k < 3; ++k) {
        lambda[k] = dot(n, cross(ev[(k + 1) % 3], ev[(k + 2) % 3])) / T(area2_[t]);
        inside = inside && value_of(lambda[k]) >= -kOnEdge;
      }
      if (inside && std::abs(value_of(h)) <= on_cage_) {  // on the face
        std::fill(w, w + m, T(0.0));
        for (int k = 0; k < 3; ++k) w[v[k]] = lambda[k];
        return;
      }
      if (!inside) {
        // Beside the triangle: skipped only when its plane is near compared with the triangle
        // itself. Near an edge of it (a point just outside the cage by an edge) the contribution
        // is not small, and the determinant form is accurate there.
        const Vec3 ex[3] = {Vec3(value_of(ev[0].x), value_of(ev[0].y), value_of(ev[0].z)),
                            Vec3(value_of(ev[1].x), value_of(ev[1].y), value_of(ev[1].z)),
                            Vec3(value_of(ev[2].x), value_of(ev[2].y), value_of(ev[2].z))};
        if (std::abs(value_of(h)) <= kNearPlane * distance_to_edges(ex)) continue;
      }
    }
    // Thiery, Memari, Boubekeur 2018, "simple code": theta_j = 2 asin(|u_j+1 - u_j+2| / 2),
    // N_j = e_j+1 x e_j+2, w_i += (1 / D) sum_j theta_j N_i . N_j / (2 |N_j|), D = e_0 . N_0.
    V<T> u[3];
    for (int k = 0; k < 3; ++k) u[k] = scaled(ev[k], T(1.0) / d[v[k]]);
    T theta[3], length[3];
    V<T> normal[3];
    for (int k = 0; k < 3; ++k) {
      T half = norm(sub(u[(k + 1) % 3], u[(k + 2) % 3])) * T(0.5);
      if (value_of(half) > 1.0) half = T(1.0);  // rounding past a diameter
      theta[k] = T(2.0) * asin(half);
      normal[k] = cross(ev[(k + 1) % 3], ev[(k + 2) % 3]);
      length[k] = norm(normal[k]);
    }
    const T det = dot(ev[0], normal[0]);
    for (int i = 0; i < 3; ++i) {
      T sum(0.0);
      for (int j = 0; j < 3; ++j)
        if (value_of(length[j]) > 0.0) sum += theta[j] * dot(normal[i], normal[j]) / (T(2.0) * length[j]);
      w[v[i]] += sum / det;
    }
  }
  T total(0.0);
  for (std::size_t j = 0; j < m; ++j) total += w[j];
  for (std::size_t j = 0; j < m; ++j) w[j] = w[j] / total;
}

void MeanValueCage::coordinates(const Vec3& x, double* w, double* dw) const {
  const std::size_t m = vertex_count();
  if (!dw) {
    const double xd[3] = {x.x(), x.y(), x.z()};
    weights(xd, w);
    return;
  }
  const Dual3 xd[3] = {Dual3::variable(x.x(), 0), Dual3::variable(x.y(), 1), Dual3::variable(x.z(), 2)};
  thread_local std::vector<Dual3> result;  // not scratch<Dual3>(): weights() keeps e and d there
  result.resize(m);
  weights(xd, result.data());
  for (std::size_t j = 0; j < m; ++j) {
    w[j] = result[j].v;
    for (int a = 0; a < 3; ++a) dw[3 * j + a] = result[j].d[a];
  }
}

void MeanValueCage::coordinate_rows(const double* points, std::size_t n, double* w) const {
  const MeanValueCageView view{rest_cage_points().data(), vertex_count(), flat_triangles_.data(),
                               flat_normals_.data(),      normal_.size(),  on_cage_,
                               kNearPlane};
  const std::size_t m = vertex_count();
  std::vector<unsigned char> guarded(n);
  mean_value_rows(points, n, view, w, guarded.data());
  for (std::size_t i = 0; i < n; ++i)  // on a vertex or near a face's plane: the guarded branches
    if (guarded[i]) weights(points + 3 * i, w + i * m);
}

}  // namespace deformkit
