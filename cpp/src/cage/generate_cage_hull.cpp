// Seidel 1991, "Small-dimensional linear programming and convex hulls made easy": add the
// constraints one by one; when the optimum so far violates one, the new optimum lies on its
// boundary, a program of one dimension less over the constraints before it.
#include "cage/generate_cage_hull.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace deformkit::cage_generation {

namespace {

using Vec2 = Eigen::Vector2d;

struct HalfPlane {
  Vec2 normal;
  double offset;
};

// Minimizes objective . (q0 + r d) over r with every half-plane and |r| <= bound.
std::optional<Vec2> lowest_on_line(const Vec2& objective, const Vec2& q0, const Vec2& d,
                                   const std::vector<HalfPlane>& planes, std::size_t count, double bound,
                                   double tol) {
  double lo = -bound, hi = bound;
  for (std::size_t k = 0; k < count; ++k) {
    const double a = planes[k].normal.dot(d), rhs = planes[k].offset - planes[k].normal.dot(q0);
    if (std::abs(a) <= 1e-12) {
      if (rhs > tol) return std::nullopt;
    } else if (a > 0) {
      lo = std::max(lo, rhs / a);
    } else {
      hi = std::min(hi, rhs / a);
    }
  }
  if (lo > hi + tol) return std::nullopt;
  const double r = objective.dot(d) > 0 ? lo : objective.dot(d) < 0 ? hi : 0.5 * (lo + hi);
  return q0 + std::clamp(r, std::min(lo, hi), std::max(lo, hi)) * d;
}

// Minimizes objective . q over the square |q|_inf <= bound cut by the half-planes `cuts`.
std::optional<Vec2> lowest_in_plane(const Vec2& objective, std::vector<HalfPlane> cuts, double bound,
                                    double tol) {
  std::vector<HalfPlane> planes = {{Vec2(1, 0), -bound}, {Vec2(-1, 0), -bound}, {Vec2(0, 1), -bound}, {Vec2(0, -1), -bound}};
  planes.insert(planes.end(), cuts.begin(), cuts.end());
  Vec2 q(objective[0] > 0 ? -bound : bound, objective[1] > 0 ? -bound : bound);
  for (std::size_t i = 4; i < planes.size(); ++i) {
    if (planes[i].normal.dot(q) >= planes[i].offset - tol) continue;
    const Vec2 n = planes[i].normal;
    const double len2 = n.squaredNorm();
    if (len2 <= 1e-24) return std::nullopt;  // 0 >= positive offset: nothing satisfies it
    const Vec2 q0 = n * (planes[i].offset / len2);
    const Vec2 d(-n[1], n[0]);
    const auto next = lowest_on_line(objective, q0, d / std::sqrt(len2), planes, i, 4.0 * bound, tol);
    if (!next) return std::nullopt;
    q = *next;
  }
  return q;
}

}  // namespace

std::optional<Vec3> lowest_point(const Vec3& objective, const std::vector<HalfSpace>& constraints,
                                 const Vec3& lo, const Vec3& hi) {
  std::vector<HalfSpace> all;
  all.reserve(constraints.size() + 6);
  for (int k = 0; k < 3; ++k) {
    all.push_back({Vec3::Unit(k), lo[k]});
    all.push_back({-Vec3::Unit(k), -hi[k]});
  }
  all.insert(all.end(), constraints.begin(), constraints.end());
  const double scale = (hi - lo).norm() + lo.cwiseAbs().maxCoeff() + hi.cwiseAbs().maxCoeff();
  const double tol = 1e-12 * scale;
  Vec3 x;
  for (int k = 0; k < 3; ++k) x[k] = objective[k] > 0 ? lo[k] : hi[k];
  for (std::size_t i = 6; i < all.size(); ++i) {
    const HalfSpace& h = all[i];
    if (h.normal.dot(x) >= h.offset - tol) continue;
    // The plane h, seen from its point o along an orthonormal pair u, w.
    const Vec3 o = h.normal * h.offset;
    const Vec3 u = h.normal.unitOrthogonal(), w = h.normal.cross(u);
    std::vector<HalfPlane> planes;
    planes.reserve(i);
    for (std::size_t j = 0; j < i; ++j)
      planes.push_back({Vec2(all[j].normal.dot(u), all[j].normal.dot(w)), all[j].offset - all[j].normal.dot(o)});
    const double bound = (o - 0.5 * (lo + hi)).norm() + (hi - lo).norm();
    const auto q = lowest_in_plane(Vec2(objective.dot(u), objective.dot(w)), std::move(planes), bound, tol);
    if (!q) return std::nullopt;
    x = o + (*q)[0] * u + (*q)[1] * w;
  }
  return x;
}

}  // namespace deformkit::cage_generation
