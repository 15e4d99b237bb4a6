#pragma once
// The Green coordinate tests' cages and helpers (test_green_coordinates.cpp, test_green_exterior.cpp):
// outward triangle cages (a cube, a perturbed octahedron, a bumpy icosphere), the coordinates of a
// point, Green's identity, and the deformed map F with its Jacobian.
#include "cage/green_coordinates.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

namespace deformkit::green_test {

using Vec3 = Eigen::Vector3d;
constexpr double kPi = 3.14159265358979323846;

struct Cage {
  std::vector<double> points;
  std::vector<int> triangles;
  std::size_t m() const { return points.size() / 3; }
  std::size_t t() const { return triangles.size() / 3; }
  Vec3 point(int i) const { return Vec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]); }
  Vec3 corner(std::size_t j, int k) const { return point(triangles[3 * j + k]); }
  Vec3 normal(std::size_t j) const {
    return (corner(j, 1) - corner(j, 0)).cross(corner(j, 2) - corner(j, 0)).normalized();
  }
  TriangleCageView view() const { return {points.data(), m(), triangles.data(), t()}; }
};

// Triangles of a cage star-shaped about the origin, turned to face away from it.
inline void orient_outward(Cage& c) {
  for (std::size_t j = 0; j < c.t(); ++j) {
    const Vec3 centroid = (c.corner(j, 0) + c.corner(j, 1) + c.corner(j, 2)) / 3.0;
    const Vec3 nn = (c.corner(j, 1) - c.corner(j, 0)).cross(c.corner(j, 2) - c.corner(j, 0));
    if (nn.dot(centroid) < 0) std::swap(c.triangles[3 * j + 1], c.triangles[3 * j + 2]);
  }
}

// [-1, 1]^3, vertex i at (+-1, +-1, +-1) by the bits of i; every face split along the diagonal
// whose two free coordinates are equal, so feet of points with y = z (and so on) lie on it.
inline Cage cube() {
  Cage c;
  for (int i = 0; i < 8; ++i)
    for (int a = 0; a < 3; ++a) c.points.push_back((i >> a) & 1 ? 1.0 : -1.0);
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      auto corner = [&](int bu, int bv) { return (side << axis) | (bu << u) | (bv << v); };
      const int lo = corner(0, 0), hi = corner(1, 1);
      for (int other : {corner(1, 0), corner(0, 1)}) c.triangles.insert(c.triangles.end(), {lo, other, hi});
    }
  orient_outward(c);
  return c;
}

// An octahedron with every vertex moved at random: no symmetry left to hide a sign error.
inline Cage perturbed_octahedron() {
  Cage c;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.25, 0.25);
  for (int a = 0; a < 3; ++a)
    for (double s : {1.0, -1.0}) {
      Vec3 p = Vec3::Zero();
      p[a] = s * (1.0 + u(rng));
      for (int b = 0; b < 3; ++b)
        if (b != a) p[b] += u(rng);
      c.points.insert(c.points.end(), {p.x(), p.y(), p.z()});
    }
  for (int sx : {0, 1})
    for (int sy : {2, 3})
      for (int sz : {4, 5}) c.triangles.insert(c.triangles.end(), {sx, sy, sz});
  orient_outward(c);
  return c;
}

// An icosahedron subdivided once (42 vertices, 80 triangles), its vertices at random radii in
// [0.8, 1.2]: irregular and not convex.
inline Cage bumpy_icosphere() {
  const double g = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> v = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0}, {0, -1, g}, {0, 1, g},
                         {0, -1, -g}, {0, 1, -g}, {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
  std::vector<int> f = {0, 11, 5, 0, 5,  1,  0, 1, 7, 0, 7,  10, 0, 10, 11, 1, 5, 9, 5, 11,
                        4, 11, 10, 2, 10, 7, 6, 7, 1, 8, 3,  9,  4, 3,  4,  2, 3, 2, 6, 3,
                        6, 8,  3,  8, 9,  4, 9, 5, 2, 4, 11, 6,  2, 10, 8,  6, 7, 9, 8, 1};
  std::vector<int> refined;
  auto midpoint = [&](int a, int b) {
    const Vec3 m = 0.5 * (v[a] + v[b]);
    for (std::size_t i = 12; i < v.size(); ++i)
      if ((v[i] - m).norm() < 1e-12) return int(i);
    v.push_back(m);
    return int(v.size() - 1);
  };
  for (std::size_t j = 0; j < f.size(); j += 3) {
    const int a = f[j], b = f[j + 1], c = f[j + 2];
    const int ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    refined.insert(refined.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
  }
  Cage c;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> r(0.8, 1.2);
  for (const Vec3& p : v) {
    const Vec3 q = p.normalized() * r(rng);
    c.points.insert(c.points.end(), {q.x(), q.y(), q.z()});
  }
  c.triangles = refined;
  orient_outward(c);
  return c;
}

struct Coordinates {
  std::vector<double> phi, psi, dphi, dpsi;
  GreenSide side;
};

inline Coordinates coordinates(const Cage& c, const Vec3& x, bool gradients = false) {
  Coordinates k;
  k.phi.assign(c.m(), -7.0);  // garbage in: the functions overwrite
  k.psi.assign(c.t(), -7.0);
  if (gradients) {
    k.dphi.assign(3 * c.m(), -7.0);
    k.dpsi.assign(3 * c.t(), -7.0);
  }
  const double p[3] = {x.x(), x.y(), x.z()};
  k.side = green_coordinates(p, c.view(), k.phi.data(), k.psi.data(), gradients ? k.dphi.data() : nullptr,
                             gradients ? k.dpsi.data() : nullptr);
  return k;
}

inline double sum(const std::vector<double>& a) {
  double s = 0;
  for (double v : a) s += v;
  return s;
}

// Green's third identity for u(x) = x: sum phi_i v_i + sum psi_j n_j (Lipman et al. 2008, §3).
inline Vec3 reproduced(const Cage& c, const Coordinates& k) {
  Vec3 r = Vec3::Zero();
  for (std::size_t i = 0; i < c.m(); ++i) r += k.phi[i] * c.point(int(i));
  for (std::size_t j = 0; j < c.t(); ++j) r += k.psi[j] * c.normal(j);
  return r;
}

inline bool all_finite(const std::vector<double>& a) {
  return std::all_of(a.begin(), a.end(), [](double v) { return std::isfinite(v); });
}

// A point of triangle j away from its edges, from barycentrics in [0.15, 0.7].
inline Vec3 point_on_triangle(const Cage& c, std::size_t j, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.15, 0.7);
  double a = u(rng), b = u(rng);
  if (a + b > 0.85) {
    a *= 0.85 / (a + b);
    b *= 0.85 / (a + b);
  }
  return (1 - a - b) * c.corner(j, 0) + a * c.corner(j, 1) + b * c.corner(j, 2);
}

inline Cage deformed(const Cage& rest, const std::function<Vec3(const Vec3&)>& map) {
  Cage d = rest;
  for (std::size_t i = 0; i < rest.m(); ++i) {
    const Vec3 q = map(rest.point(int(i)));
    for (int a = 0; a < 3; ++a) d.points[3 * i + a] = q[a];
  }
  return d;
}

// F(x) for a deformed cage, with the stretch factors of rest -> deformed or s = 1.
struct GreenMap {
  const Cage& rest;
  const Cage& moved;
  bool stretch = true;
  Vec3 operator()(const Vec3& x, Eigen::Matrix3d* jacobian = nullptr) const {
    const Coordinates k = coordinates(rest, x, jacobian != nullptr);
    std::vector<double> s(rest.t()), normals(3 * rest.t());
    green_stretch_factors(rest.points.data(), moved.points.data(), rest.triangles.data(), rest.t(), s.data());
    green_scaled_normals(moved.points.data(), rest.triangles.data(), rest.t(), stretch ? s.data() : nullptr,
                         normals.data());
    double out[3], jac[9];
    green_deform_point(k.phi.data(), k.psi.data(), jacobian ? k.dphi.data() : nullptr,
                       jacobian ? k.dpsi.data() : nullptr, moved.points.data(), rest.m(), normals.data(), rest.t(),
                       out, jacobian ? jac : nullptr);
    if (jacobian)
      for (int r = 0; r < 3; ++r)
        for (int col = 0; col < 3; ++col) (*jacobian)(r, col) = jac[3 * r + col];
    return Vec3(out[0], out[1], out[2]);
  }
};

// A non-rigid edit: every vertex moved by a smooth bend plus a fixed random jitter.
inline Cage edited(const Cage& rest, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.15, 0.15);
  Cage d = deformed(rest, [&](const Vec3& p) -> Vec3 {
    const double angle = 0.4 * p.z();
    return Vec3(std::cos(angle) * p.x() - std::sin(angle) * p.y() + 0.2 * p.z() * p.z(),
                std::sin(angle) * p.x() + std::cos(angle) * p.y(), 1.3 * p.z()) +
           Vec3(u(rng), u(rng), u(rng));
  });
  return d;
}


struct NamedCage {
  const char* name;
  Cage cage;
};

inline std::vector<NamedCage> test_cages() {
  return {{"cube", cube()}, {"octahedron", perturbed_octahedron()}, {"icosphere", bumpy_icosphere()}};
}

// Every cage here is star-shaped about the origin, so lambda * (a point of the surface) is inside
// for 0 < lambda < 1.
inline std::vector<Vec3> interior_points(const Cage& c, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> face(0, c.t() - 1);
  std::uniform_real_distribution<double> lambda(0.05, 0.95);
  std::vector<Vec3> out;
  for (int i = 0; i < count; ++i) out.push_back(lambda(rng) * point_on_triangle(c, face(rng), rng));
  return out;
}


}  // namespace deformkit::green_test
