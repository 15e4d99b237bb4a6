// The exterior extension of Green coordinates (cpp/src/cage/green_exterior.cpp) against an
// independent transcription of its formula (per-face continuations from a 3 x 3 solve, distances
// from projections and segments), the Lipschitz bound derived in docs/math/green_coordinates.md,
// "Exterior extension", central differences where the nearest face changes, and dense scans
// across those places (where the nearest-face rule jumped).
#include "cage/green_coordinates.hpp"
#include "cage/green_test_cages.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

using namespace deformkit;
using namespace deformkit::green_test;

namespace {

using Mat3 = Eigen::Matrix3d;

// A regular tetrahedron with its vertices moved a little: every vertex and edge is a place where
// several faces are equally near.
Cage edited_tetrahedron() {
  Cage c;
  const double v[4][3] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  const double nudge[4][3] = {{0.03, -0.02, 0.05}, {-0.04, 0.01, 0.02}, {0.02, 0.05, -0.03}, {-0.01, -0.03, 0.04}};
  for (int i = 0; i < 4; ++i)
    for (int a = 0; a < 3; ++a) c.points.push_back(v[i][a] + nudge[i][a]);
  c.triangles = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};
  orient_outward(c);
  return c;
}

double segment_distance(const Vec3& x, const Vec3& a, const Vec3& b) {
  const double t = std::clamp((x - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
  return (x - a - t * (b - a)).norm();
}

// Face j's continuation, written independently: x - v0 = a (v1 - v0) + b (v2 - v0) + c n solved
// for (a, b, c); then C_j(x) = (1 - a - b) v0' + a v1' + b v2' + c s_j n'_j, an affine map of x whose
// Jacobian is A_j = [v1' - v0', v2' - v0', s_j n'_j] M^-1; d_j the distance to the closed triangle.
struct Continuation {
  Vec3 value;
  Mat3 jacobian;
  double distance;
};

Continuation continuation(const Cage& rest, const Cage& moved, const double* scaled_normals, std::size_t j,
                          const Vec3& x) {
  Mat3 m, md;
  m << rest.corner(j, 1) - rest.corner(j, 0), rest.corner(j, 2) - rest.corner(j, 0), rest.normal(j);
  const Vec3 sn(scaled_normals[3 * j], scaled_normals[3 * j + 1], scaled_normals[3 * j + 2]);
  md << moved.corner(j, 1) - moved.corner(j, 0), moved.corner(j, 2) - moved.corner(j, 0), sn;
  const Vec3 abc = m.lu().solve(x - rest.corner(j, 0));
  Continuation out;
  out.value = moved.corner(j, 0) + md * abc;
  out.jacobian = md * m.inverse();
  const bool over_face = abc[0] >= 0 && abc[1] >= 0 && abc[0] + abc[1] <= 1;
  out.distance = over_face ? std::abs(abc[2])
                           : std::min({segment_distance(x, rest.corner(j, 0), rest.corner(j, 1)),
                                       segment_distance(x, rest.corner(j, 1), rest.corner(j, 2)),
                                       segment_distance(x, rest.corner(j, 2), rest.corner(j, 0))});
  return out;
}

// The documented blend E(x) = sum_j w_j C_j(x), w_j = d_j^-2 / sum d^-2, and the bound on its
// Jacobian derived from grad w_j = -2 w_j (grad d_j / d_j - sum_k w_k grad d_k / d_k), |grad d| = 1:
// |J_E| <= max_j |A_j| + 2 sum_j w_j |C_j - E| (1/d_j + sum_k w_k / d_k).
struct Blend {
  Vec3 value;
  double jacobian_bound;
};

Blend blend(const Cage& rest, const Cage& moved, const double* scaled_normals, const Vec3& x) {
  std::vector<Continuation> c;
  double total = 0;
  for (std::size_t j = 0; j < rest.t(); ++j) {
    c.push_back(continuation(rest, moved, scaled_normals, j, x));
    total += 1.0 / (c.back().distance * c.back().distance);
  }
  Blend b{Vec3::Zero(), 0.0};
  double mean_inverse = 0, largest_a = 0;
  for (const Continuation& k : c) {
    const double w = 1.0 / (k.distance * k.distance) / total;
    b.value += w * k.value;
    mean_inverse += w / k.distance;
    largest_a = std::max(largest_a, k.jacobian.operatorNorm());
  }
  b.jacobian_bound = largest_a;
  for (const Continuation& k : c) {
    const double w = 1.0 / (k.distance * k.distance) / total;
    b.jacobian_bound += 2 * w * (k.value - b.value).norm() * (1.0 / k.distance + mean_inverse);
  }
  return b;
}

std::vector<double> scaled_normals(const Cage& rest, const Cage& moved) {
  std::vector<double> s(rest.t()), normals(3 * rest.t());
  green_stretch_factors(rest.points.data(), moved.points.data(), rest.triangles.data(), rest.t(), s.data());
  green_scaled_normals(moved.points.data(), rest.triangles.data(), rest.t(), s.data(), normals.data());
  return normals;
}

// The raw integrals' share of F and its Jacobian (no extension).
Vec3 raw_map(const Cage& rest, const Cage& moved, const std::vector<double>& normals, const Vec3& x, Mat3* jacobian) {
  std::vector<double> phi(rest.m()), psi(rest.t()), dphi(3 * rest.m()), dpsi(3 * rest.t());
  const double p[3] = {x.x(), x.y(), x.z()};
  green_integrals(p, rest.view(), phi.data(), psi.data(), dphi.data(), dpsi.data());
  double out[3], jac[9];
  green_deform_point(phi.data(), psi.data(), dphi.data(), dpsi.data(), moved.points.data(), rest.m(), normals.data(),
                     rest.t(), out, jac);
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 3; ++col) (*jacobian)(r, col) = jac[3 * r + col];
  return Vec3(out[0], out[1], out[2]);
}

struct ExteriorCase {
  const char* name;
  Cage rest, moved;
};

std::vector<ExteriorCase> exterior_cases() {
  std::vector<ExteriorCase> out;
  for (auto& [name, c] : test_cages()) out.push_back({name, c, edited(c, 97)});
  const Cage tet = edited_tetrahedron();
  out.push_back({"tetrahedron", tet, edited(tet, 101)});
  return out;
}

// Random directions at 1-3 times the cage's radius (every test cage has radius < 2 about 0).
std::vector<Vec3> exterior_points(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> r(1.0, 3.0);
  std::vector<Vec3> out;
  for (int i = 0; i < count; ++i) out.push_back(Vec3(g(rng), g(rng), g(rng)).normalized() * (2.0 * r(rng)));
  return out;
}

}  // namespace

// Outside, F = (the raw integrals' share) + the documented blend of the per-face continuations, and
// the extension's Jacobian stays within the bound derived from the blend's weights.
TEST(GreenExterior, IsTheDocumentedBlendWithinItsLipschitzBound) {
  double worst = 0, tightest = 0;
  for (const ExteriorCase& k : exterior_cases()) {
    const std::vector<double> normals = scaled_normals(k.rest, k.moved);
    const GreenMap map{k.rest, k.moved, true};
    for (const Vec3& x : exterior_points(300, 7)) {
      Mat3 j, j_raw;
      const Vec3 f = map(x, &j), f_raw = raw_map(k.rest, k.moved, normals, x, &j_raw);
      const Blend b = blend(k.rest, k.moved, normals.data(), x);
      const double error = (f - f_raw - b.value).norm();
      EXPECT_LT(error, 1e-13 * (1 + f.norm())) << k.name << " x=" << x.transpose();
      worst = std::max(worst, error);
      const double extension_jacobian = (j - j_raw).operatorNorm();
      EXPECT_LE(extension_jacobian, b.jacobian_bound * (1 + 1e-12)) << k.name << " x=" << x.transpose();
      tightest = std::max(tightest, extension_jacobian / b.jacobian_bound);
    }
  }
  std::printf("[green] exterior blend against its transcription: max %.3g; |J_E| / derived bound: max %.3g\n",
              worst, tightest);
}

// Where the nearest face changes (over a split quad's diagonal, between a face's prism and an edge's
// wedge, in a vertex's region) the weights' derivatives make the Jacobian: central differences. F is
// C^1 but not C^2 there (a distance's second derivative jumps between Voronoi regions), so the
// differences' error is O(h), not O(h^2): h = 1e-7 keeps it and the rounding (1e-16 / h) near 1e-8.
TEST(GreenExterior, GradientsMatchCentralDifferencesWhereTheNearestFaceChanges) {
  const double h = 1e-7;
  std::vector<std::pair<ExteriorCase, std::vector<Vec3>>> cases;
  const Cage c = cube();
  std::vector<Vec3> cube_points;
  for (double d : {0.05, 0.3, 1.0})
    for (double e : {0.0, 1e-7, -3e-4}) {
      cube_points.push_back(Vec3(0.2 + e, 0.2 - e, 1 + d));  // over the +z face's diagonal
      cube_points.push_back(Vec3(1 + e, 1 + d, 0.3));       // the +y face's prism against the edge's wedge
      cube_points.push_back(Vec3(1 + d, 1 + d + e, 1 + d));  // the vertex's region
    }
  cases.push_back({{"cube", c, edited(c, 71)}, cube_points});
  const Cage tet = edited_tetrahedron();
  std::vector<Vec3> tet_points;
  for (std::size_t i = 0; i < tet.m(); ++i)
    for (double d : {0.05, 0.5, 2.0}) tet_points.push_back(tet.point(int(i)) * (1 + d) + Vec3(1e-9, 0, 0));
  cases.push_back({{"tetrahedron", tet, edited(tet, 101)}, tet_points});
  double worst = 0;
  for (const auto& [k, points] : cases)
    for (bool stretch : {true, false}) {
      const GreenMap map{k.rest, k.moved, stretch};
      for (const Vec3& x : points) {
        Mat3 j;
        map(x, &j);
        for (int a = 0; a < 3; ++a) {
          Vec3 e = Vec3::Zero();
          e[a] = h;
          const Vec3 fd = (map(x + e) - map(x - e)) / (2 * h);
          const double difference = (j.col(a) - fd).norm() / std::max(1.0, j.norm());
          EXPECT_LT(difference, 1e-6) << k.name << " x=" << x.transpose() << " axis " << a;
          worst = std::max(worst, difference);
        }
      }
    }
  std::printf("[green] exterior Jacobian against central differences (h = 1e-7) where the nearest face "
              "changes: max relative difference %.3g\n",
              worst);
}

// Dense 1-D scans across the places where the nearest face changes: each step moves F by at most
// the step times the larger Jacobian norm at its ends (Frobenius, above the operator norm) with 1%
// for the Jacobian's change over a step, plus rounding. The nearest-face rule jumped there by
// 6e-3 .. 0.2 at these distances.
TEST(GreenExterior, DenseScansAcrossFormerSwitchesShowNoJump) {
  const Cage c = cube();
  const Cage moved = edited(c, 71);
  const GreenMap map{c, moved, true};
  const int samples = 2001;
  const double half_width = 0.02, step = 2 * half_width / (samples - 1);
  double worst_ratio = 0;
  for (double d : {0.1, 0.5, 1.5}) {
    const Vec3 starts[3] = {Vec3(0.2, 0.2, 1 + d), Vec3(1, 1 + d, 0.3), Vec3(1 + d, 1 + d, 1 + 0.5 * d)};
    const Vec3 across[3] = {Vec3(1, -1, 0).normalized(), Vec3(1, 0, 0), Vec3(1, -1, 0).normalized()};
    for (int line = 0; line < 3; ++line) {
      Mat3 j_prev;
      Vec3 f_prev = map(starts[line] - half_width * across[line], &j_prev);
      for (int i = 1; i < samples; ++i) {
        Mat3 j;
        const Vec3 f = map(starts[line] + (i * step - half_width) * across[line], &j);
        const double bound = 1.01 * step * std::max(j.norm(), j_prev.norm()) + 1e-13 * (1 + f.norm());
        const double moved_by = (f - f_prev).norm();
        EXPECT_LE(moved_by, bound) << "d=" << d << " line " << line << " sample " << i;
        worst_ratio = std::max(worst_ratio, moved_by / bound);
        f_prev = f;
        j_prev = j;
      }
    }
  }
  std::printf("[green] dense scans across former switches: largest step / its Lipschitz bound %.3g\n", worst_ratio);
}

// A one-ulp move of each coordinate, and a 1e-9 move, outside: F moves by at most the move times the
// Jacobian's norm (with 1% for its change) plus rounding (the nearest-face rule jumped by up to 1.1
// on the tetrahedron where faces tie).
TEST(GreenExterior, TinyMovesOutsideStayWithinTheLipschitzBound) {
  double worst_ratio = 0;
  for (const ExteriorCase& k : exterior_cases()) {
    const GreenMap map{k.rest, k.moved, true};
    std::vector<Vec3> points = exterior_points(400, 13);
    for (std::size_t i = 0; i < k.rest.m(); ++i) points.push_back(2.0 * k.rest.point(int(i)));  // faces tie
    for (const Vec3& x : points) {
      Mat3 j;
      const Vec3 f = map(x, &j);
      Vec3 ulp;
      for (int a = 0; a < 3; ++a) ulp[a] = std::nextafter(x[a], 2 * x[a] + 1) - x[a];
      for (const Vec3& move : {ulp, Vec3(1e-9, -1e-9, 1e-9)}) {
        Mat3 j_moved;
        const Vec3 g = map(x + move, &j_moved);
        const double bound = 1.01 * move.norm() * std::max(j.norm(), j_moved.norm()) + 1e-14 * (1 + f.norm());
        EXPECT_LE((g - f).norm(), bound) << k.name << " x=" << x.transpose();
        worst_ratio = std::max(worst_ratio, (g - f).norm() / bound);
      }
    }
  }
  std::printf("[green] one-ulp and 1e-9 moves outside: largest change / its Lipschitz bound %.3g\n", worst_ratio);
}
