// Green coordinates (cpp/src/cage/green_coordinates.hpp) against independent truths: Green's third
// identity (partition of unity, linear reproduction), the paper's own Algorithm 1, central finite
// differences, similarity maps, and continuity across the cage surface.
#include "cage/green_coordinates.hpp"
#include "cage/green_rows.hpp"
#include "cage/green_test_cages.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <vector>

using namespace deformkit;
using namespace deformkit::green_test;

namespace {

// ---- The paper's Algorithm 1 (with the GCTriInt guard of its line-degenerate case), written
// from Lipman et al. 2008, Algorithm 1, as a second, independent derivation of the same integrals.
double angle_between(const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); }

double gc_tri_int(const Vec3& p, const Vec3& v1, const Vec3& v2, const Vec3& eta) {
  const double alpha = angle_between(v2 - v1, p - v1), beta = angle_between(v1 - p, v2 - p);
  if (std::abs(std::sin(alpha)) < 1e-12 || (p - v1).norm() < 1e-14) return 0.0;
  const double lambda = (p - v1).squaredNorm() * std::sin(alpha) * std::sin(alpha);
  const double c = (p - eta).squaredNorm();
  auto integral = [&](double theta) {
    const double S = std::sin(theta), C = std::cos(theta), sc = std::sqrt(c), sl = std::sqrt(lambda);
    const double sign = S > 0 ? 1.0 : S < 0 ? -1.0 : 0.0;
    return -sign / 2.0 *
           (2.0 * sc * std::atan(sc * C / std::sqrt(lambda + S * S * c)) +
            sl * std::log(2.0 * sl * S * S / ((1 - C) * (1 - C)) *
                          (1 - 2.0 * c * C /
                                   (c * (1 + C) + lambda + std::sqrt(lambda * lambda + lambda * c * S * S)))));
  };
  return -1.0 / (4 * kPi) * std::abs(integral(kPi - alpha) - integral(kPi - alpha - beta) - std::sqrt(c) * beta);
}

void paper_algorithm(const Cage& cage, const Vec3& eta, std::vector<double>& phi, std::vector<double>& psi) {
  phi.assign(cage.m(), 0.0);
  psi.assign(cage.t(), 0.0);
  for (std::size_t j = 0; j < cage.t(); ++j) {
    Vec3 v[3];
    for (int l = 0; l < 3; ++l) v[l] = cage.corner(j, l) - eta;
    const Vec3 n = cage.normal(j), p = v[0].dot(n) * n;
    double I_sum = 0;
    Vec3 N[3];
    double II[3];
    for (int l = 0; l < 3; ++l) {
      const Vec3 &a = v[l], &b = v[(l + 1) % 3];
      const double orientation = (a - p).cross(b - p).dot(n);
      const double s = orientation > 0 ? 1.0 : orientation < 0 ? -1.0 : 0.0;
      I_sum += s * gc_tri_int(p, a, b, Vec3::Zero());
      II[l] = gc_tri_int(Vec3::Zero(), b, a, Vec3::Zero());
      const Vec3 q = b.cross(a);
      N[l] = q.norm() > 0 ? Vec3(q / q.norm()) : Vec3::Zero();
    }
    const double I = -std::abs(I_sum);
    psi[j] = -I;
    Vec3 w = n * I;
    for (int l = 0; l < 3; ++l) w += N[l] * II[l];
    if (w.norm() > 1e-12)
      for (int l = 0; l < 3; ++l)
        phi[cage.triangles[3 * j + l]] += N[(l + 1) % 3].dot(w) / N[(l + 1) % 3].dot(v[l]);
  }
}

}  // namespace

// The cube's triangles face outward and counter-clockwise: the test cages are what the tests think.
TEST(GreenCoordinates, TestCagesAreOutward) {
  for (const auto& [name, c] : test_cages()) {
    double volume = 0;  // divergence theorem: V = 1/3 sum_j area_j n_j . centroid_j
    for (std::size_t j = 0; j < c.t(); ++j) volume += c.corner(j, 0).dot(c.corner(j, 1).cross(c.corner(j, 2))) / 6.0;
    EXPECT_GT(volume, 0.5) << name;
  }
  EXPECT_NEAR([] {
    const Cage c = cube();
    double v = 0;
    for (std::size_t j = 0; j < c.t(); ++j) v += c.corner(j, 0).dot(c.corner(j, 1).cross(c.corner(j, 2))) / 6.0;
    return v;
  }(), 8.0, 1e-14);
}

// Green's third identity (Lipman et al. 2008, §3): sum phi = 1 and sum phi v + sum psi n = x inside.
TEST(GreenCoordinates, PartitionOfUnityAndLinearReproductionInside) {
  for (const auto& [name, c] : test_cages())
    for (const Vec3& x : interior_points(c, 200, 3)) {
      const Coordinates k = coordinates(c, x);
      EXPECT_FALSE(k.side.outside) << name;
      EXPECT_NEAR(sum(k.phi), 1.0, 1e-13) << name << " x=" << x.transpose();
      EXPECT_LT((reproduced(c, k) - x).norm(), 1e-13) << name << " x=" << x.transpose();
    }
}

// The closed form of docs/math/green_coordinates.md against the paper's Algorithm 1, an independent
// derivation (sub-triangles around the foot point, GCTriInt) at points well inside.
TEST(GreenCoordinates, AgreesWithThePapersAlgorithm) {
  double worst = 0;
  for (const auto& [name, c] : test_cages())
    for (const Vec3& x : interior_points(c, 50, 5)) {
      const Coordinates k = coordinates(c, x);
      std::vector<double> phi, psi;
      paper_algorithm(c, x, phi, psi);
      for (std::size_t i = 0; i < c.m(); ++i) {
        EXPECT_NEAR(k.phi[i], phi[i], 1e-10) << name << " phi " << i << " x=" << x.transpose();
        worst = std::max(worst, std::abs(k.phi[i] - phi[i]));
      }
      for (std::size_t j = 0; j < c.t(); ++j) {
        EXPECT_NEAR(k.psi[j], psi[j], 1e-10) << name << " psi " << j << " x=" << x.transpose();
        worst = std::max(worst, std::abs(k.psi[j] - psi[j]));
      }
    }
  std::printf("[green] closed form vs paper's Algorithm 1, max |difference| = %.3g\n", worst);
}

// Near a face, from both sides: the integrals keep full precision (no 0/0 in the double layer), and
// with the exterior extension the identity holds outside too.
TEST(GreenCoordinates, LinearReproductionNearTheSurfaceFromBothSides) {
  std::mt19937 rng(17);
  double worst_inside = 0, worst_outside = 0;
  for (const auto& [name, c] : test_cages())
    for (std::size_t j = 0; j < c.t(); ++j) {
      const Vec3 q = point_on_triangle(c, j, rng), n = c.normal(j);
      for (double d : {1e-3, 1e-6, 1e-9, 1e-12})
        for (double side : {-1.0, 1.0}) {
          const Vec3 x = q + side * d * n;
          const Coordinates k = coordinates(c, x);
          EXPECT_EQ(k.side.outside, side > 0) << name << " face " << j << " d=" << d;
          if (side > 0) {
            EXPECT_EQ(k.side.face, j) << name << " d=" << d;
          }
          EXPECT_NEAR(sum(k.phi), 1.0, 1e-12) << name << " face " << j << " d=" << side * d;
          const double error = (reproduced(c, k) - x).norm();
          EXPECT_LT(error, 1e-12) << name << " face " << j << " d=" << side * d;
          (side > 0 ? worst_outside : worst_inside) = std::max(side > 0 ? worst_outside : worst_inside, error);
        }
    }
  std::printf("[green] linear reproduction 1e-3..1e-12 from a face: max error inside %.3g, outside %.3g\n",
              worst_inside, worst_outside);
}

// Near the cage's edges and vertices, where the two triangles of an edge must agree on x's offset
// from it: radially in and out of the star-shaped cages, 1e-4..1e-12 from an edge or a vertex.
TEST(GreenCoordinates, LinearReproductionNearEdgesAndVertices) {
  std::mt19937 rng(19);
  std::uniform_real_distribution<double> u(0.2, 0.8);
  double worst = 0;
  for (const auto& [name, c] : test_cages()) {
    std::vector<Vec3> surface;
    for (std::size_t j = 0; j < c.t(); ++j) {
      const double a = u(rng);
      surface.push_back((1 - a) * c.corner(j, 0) + a * c.corner(j, 1));
    }
    for (std::size_t i = 0; i < c.m(); ++i) surface.push_back(c.point(int(i)));
    for (const Vec3& q : surface)
      for (double d : {1e-4, 1e-8, 1e-10, 1e-12})
        for (double side : {-1.0, 1.0}) {
          const Vec3 x = q * (1 + side * d);
          const Coordinates k = coordinates(c, x);
          EXPECT_EQ(k.side.outside, side > 0) << name << " q=" << q.transpose() << " d=" << side * d;
          EXPECT_NEAR(sum(k.phi), 1.0, 1e-13) << name << " q=" << q.transpose() << " d=" << side * d;
          const double error = (reproduced(c, k) - x).norm();
          EXPECT_LT(error, 1e-13) << name << " q=" << q.transpose() << " d=" << side * d;
          worst = std::max(worst, error);
        }
  }
  std::printf("[green] linear reproduction 1e-4..1e-12 from an edge or vertex, both sides: max error %.3g\n", worst);
}

// Outside, far away and in every direction (also where no face's prism holds x): the exterior
// extension keeps sum phi = 1 and linear reproduction.
TEST(GreenCoordinates, LinearReproductionOutside) {
  std::mt19937 rng(23);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> r(1.3, 4.0);
  for (const auto& [name, c] : test_cages())
    for (int i = 0; i < 200; ++i) {
      const Vec3 x = Vec3(g(rng), g(rng), g(rng)).normalized() * r(rng);
      const Coordinates k = coordinates(c, x);
      EXPECT_TRUE(k.side.outside) << name;
      EXPECT_NEAR(k.side.winding, 0.0, 1e-12) << name;
      EXPECT_NEAR(sum(k.phi), 1.0, 1e-12) << name;
      EXPECT_LT((reproduced(c, k) - x).norm(), 1e-12 * x.norm()) << name << " x=" << x.transpose();
    }
}

// The foot point on a triangle's edge line (the cube's centre projects onto every face diagonal,
// (0.99, 0.99, 0.99) onto three), on a vertex, an edge and a face: finite values and gradients.
TEST(GreenCoordinates, NoNanAtTheKnownBadPoints) {
  const Cage c = cube();
  for (const Vec3& x : {Vec3(0, 0, 0), Vec3(0.99, 0.99, 0.99), Vec3(-0.5, -0.5, -0.5), Vec3(0.3, 0.3, 0.3)}) {
    const Coordinates k = coordinates(c, x, true);
    EXPECT_TRUE(all_finite(k.phi) && all_finite(k.psi) && all_finite(k.dphi) && all_finite(k.dpsi))
        << x.transpose();
    EXPECT_NEAR(sum(k.phi), 1.0, 1e-14) << x.transpose();
    EXPECT_LT((reproduced(c, k) - x).norm(), 1e-14) << x.transpose();
  }
  // On the cage: a vertex, an edge, a face diagonal (fractional winding number), a face; and just off.
  for (const Vec3& x : {Vec3(1, 1, 1), Vec3(1, 1, 0.2), Vec3(1, 0.3, 0.3), Vec3(1, 0.2, -0.4), Vec3(1.5, 1, 1),
                        Vec3(1, 1.5, 0.3), Vec3(2, 0.4, 0.4)}) {
    const Coordinates k = coordinates(c, x, true);
    EXPECT_TRUE(all_finite(k.phi) && all_finite(k.psi) && all_finite(k.dphi) && all_finite(k.dpsi))
        << x.transpose();
    EXPECT_NEAR(sum(k.phi), 1.0, 1e-13) << x.transpose();
    EXPECT_LT((reproduced(c, k) - x).norm(), 1e-13) << x.transpose();
  }
  EXPECT_TRUE(coordinates(c, Vec3(1, 1, 1)).side.on_surface);
  EXPECT_TRUE(coordinates(c, Vec3(1, 1, 0.2)).side.on_surface);
  EXPECT_NEAR(coordinates(c, Vec3(1, 1, 0.2)).side.winding, 0.25, 1e-14);  // a right dihedral angle
  EXPECT_NEAR(coordinates(c, Vec3(1, 1, 1)).side.winding, 0.125, 1e-14);   // an octant
}

// On the cage's edges and vertices the coordinates are the limit from inside: the deformed point
// there is where points 1e-10 inside go.
TEST(GreenCoordinates, OnTheCageIsTheLimitFromInside) {
  const Cage c = cube();
  const Cage moved = edited(c, 79);
  const GreenMap map{c, moved, true};
  for (const Vec3& x : {Vec3(1, 1, 1), Vec3(-1, 1, -1), Vec3(1, 1, 0.2), Vec3(1, 0.3, 0.3), Vec3(0.4, -1, 0.4),
                        Vec3(1, 0.2, -0.4)}) {
    const Vec3 inward = -1e-10 * x.normalized();
    EXPECT_LT((map(x) - map(x + inward)).norm(), 1e-8) << x.transpose();
    EXPECT_LT((map(x) - map(x - inward)).norm(), 1e-8) << x.transpose();
  }
}

// The forward-mode gradients against central differences of the values, inside and outside.
TEST(GreenCoordinates, GradientsMatchCentralDifferences) {
  const double h = 1e-5;
  double worst = 0;
  for (const auto& [name, c] : test_cages()) {
    std::vector<Vec3> points = interior_points(c, 20, 29);
    std::mt19937 rng(31);
    for (std::size_t j = 0; j < c.t(); j += 3) points.push_back(point_on_triangle(c, j, rng) + 0.2 * c.normal(j));
    for (const Vec3& x : points) {
      const Coordinates k = coordinates(c, x, true);
      double scale = 1.0;
      for (double v : k.dphi) scale = std::max(scale, std::abs(v));
      for (double v : k.dpsi) scale = std::max(scale, std::abs(v));
      for (int a = 0; a < 3; ++a) {
        Vec3 e = Vec3::Zero();
        e[a] = h;
        const Coordinates plus = coordinates(c, x + e), minus = coordinates(c, x - e);
        for (std::size_t i = 0; i < c.m(); ++i) {
          const double fd = (plus.phi[i] - minus.phi[i]) / (2 * h);
          EXPECT_NEAR(k.dphi[3 * i + a], fd, 1e-6 * scale) << name << " dphi " << i << " x=" << x.transpose();
          worst = std::max(worst, std::abs(k.dphi[3 * i + a] - fd) / scale);
        }
        for (std::size_t j = 0; j < c.t(); ++j) {
          const double fd = (plus.psi[j] - minus.psi[j]) / (2 * h);
          EXPECT_NEAR(k.dpsi[3 * j + a], fd, 1e-6 * scale) << name << " dpsi " << j << " x=" << x.transpose();
          worst = std::max(worst, std::abs(k.dpsi[3 * j + a] - fd) / scale);
        }
      }
    }
  }
  std::printf("[green] gradients vs central differences (h = 1e-5): max relative difference %.3g\n", worst);
}

// In a face's plane off its triangle (h = 0 exactly: the cube's outside point (1.5, 0.3, 1) is in
// the planes of the +z triangles) the raw integrals are smooth, and their gradients are too.
TEST(GreenCoordinates, GradientsInAFacesPlane) {
  const Cage c = cube();
  const double h = 1e-5;
  // (3, 1, -1) is also on two edges' lines; (3, 1 + 1e-9, -1) next to one.
  for (const Vec3& x : {Vec3(1.5, 0.3, 1), Vec3(-1, 2, 0.2), Vec3(3, 1, -1), Vec3(3, 1 + 1e-9, -1)}) {
    const double p[3] = {x.x(), x.y(), x.z()};
    std::vector<double> phi(c.m()), psi(c.t()), dphi(3 * c.m()), dpsi(3 * c.t());
    green_integrals(p, c.view(), phi.data(), psi.data(), dphi.data(), dpsi.data());
    for (int a = 0; a < 3; ++a) {
      double plus[3] = {p[0], p[1], p[2]}, minus[3] = {p[0], p[1], p[2]};
      plus[a] += h;
      minus[a] -= h;
      std::vector<double> phi_p(c.m()), psi_p(c.t()), phi_m(c.m()), psi_m(c.t());
      green_integrals(plus, c.view(), phi_p.data(), psi_p.data(), nullptr, nullptr);
      green_integrals(minus, c.view(), phi_m.data(), psi_m.data(), nullptr, nullptr);
      for (std::size_t i = 0; i < c.m(); ++i)
        EXPECT_NEAR(dphi[3 * i + a], (phi_p[i] - phi_m[i]) / (2 * h), 1e-8) << x.transpose() << " phi " << i;
      for (std::size_t j = 0; j < c.t(); ++j)
        EXPECT_NEAR(dpsi[3 * j + a], (psi_p[j] - psi_m[j]) / (2 * h), 1e-8) << x.transpose() << " psi " << j;
    }
  }
}

// The stretch factor: 1 at rest, sigma under a similarity of scale sigma, and the norm of the
// triangle's 2D conformal part otherwise (a uniform in-plane stretch by k gives k).
TEST(GreenCoordinates, StretchFactors) {
  const Cage c = bumpy_icosphere();
  std::vector<double> s(c.t());
  green_stretch_factors(c.points.data(), c.points.data(), c.triangles.data(), c.t(), s.data());
  for (double v : s) EXPECT_NEAR(v, 1.0, 1e-14);
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const Cage similar = deformed(c, [&](const Vec3& p) { return Vec3(2.5 * (rotation * p) + Vec3(0.3, -1, 2)); });
  green_stretch_factors(c.points.data(), similar.points.data(), c.triangles.data(), c.t(), s.data());
  for (double v : s) EXPECT_NEAR(v, 2.5, 1e-13);
}

// A similarity of the cage with the stretch factors maps every point, inside and outside, by the
// same similarity (Lipman et al. 2008, §3: rotations and uniform scales of the normals).
TEST(GreenCoordinates, SimilarityMapsAreReproduced) {
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(1.1, Vec3(-1, 0.5, 2).normalized()).toRotationMatrix();
  const double sigma = 1.7;
  const Vec3 shift(0.4, -0.2, 1.5);
  auto similarity = [&](const Vec3& p) { return Vec3(sigma * (rotation * p) + shift); };
  std::mt19937 rng(41);
  for (const auto& [name, c] : test_cages()) {
    const Cage moved = deformed(c, similarity);
    const GreenMap map{c, moved, true};
    std::vector<Vec3> points = interior_points(c, 50, 43);
    for (std::size_t j = 0; j < c.t(); ++j) points.push_back(point_on_triangle(c, j, rng) + 0.5 * c.normal(j));
    for (const Vec3& x : points) EXPECT_LT((map(x) - similarity(x)).norm(), 1e-12) << name << " x=" << x.transpose();
  }
}

// With s = 1 the normals keep their rest length, so a scaled cage no longer scales the points.
TEST(GreenCoordinates, UnitStretchDiffersUnderScaling) {
  const Cage c = perturbed_octahedron();
  const Cage scaled = deformed(c, [](const Vec3& p) { return Vec3(2.0 * p); });
  const GreenMap with_stretch{c, scaled, true}, unit{c, scaled, false};
  for (const Vec3& x : interior_points(c, 20, 47)) {
    EXPECT_LT((with_stretch(x) - 2.0 * x).norm(), 1e-12);
    // Green's identity: F_unit = sum phi (2v) + sum psi n = 2x - sum psi n, and sum psi n = x - sum phi v
    // is far from 0 off the cage's "centre".
    const Coordinates k = coordinates(c, x);
    Vec3 psi_n = Vec3::Zero();
    for (std::size_t j = 0; j < c.t(); ++j) psi_n += k.psi[j] * c.normal(j);
    EXPECT_LT((unit(x) - (2.0 * x - psi_n)).norm(), 1e-12);
    EXPECT_GT((unit(x) - 2.0 * x).norm(), 1e-3);
  }
}

// The convenience overload (normals computed per call) is the precomputed one, bit for bit.
TEST(GreenCoordinates, DeformPointOverloadsAgree) {
  const Cage c = bumpy_icosphere();
  const Cage moved = edited(c, 83);
  std::vector<double> s(c.t()), normals(3 * c.t());
  green_stretch_factors(c.points.data(), moved.points.data(), c.triangles.data(), c.t(), s.data());
  green_scaled_normals(moved.points.data(), c.triangles.data(), c.t(), s.data(), normals.data());
  for (const Vec3& x : interior_points(c, 10, 89)) {
    const Coordinates k = coordinates(c, x, true);
    double a[3], b[3], ja[9], jb[9];
    green_deform_point(k.phi.data(), k.psi.data(), k.dphi.data(), k.dpsi.data(), moved.points.data(), c.m(),
                       normals.data(), c.t(), a, ja);
    green_deform_point(k.phi.data(), k.psi.data(), k.dphi.data(), k.dpsi.data(), moved.view(), s.data(), b, jb);
    for (int r = 0; r < 3; ++r) EXPECT_EQ(a[r], b[r]);
    for (int r = 0; r < 9; ++r) EXPECT_EQ(ja[r], jb[r]);
  }
}

// The deformed point's Jacobian from the coordinate gradients against central differences of F.
TEST(GreenCoordinates, DeformedJacobianMatchesCentralDifferences) {
  const double h = 1e-5;
  for (const auto& [name, c] : test_cages()) {
    const Cage moved = edited(c, 53);
    for (bool stretch : {true, false}) {
      const GreenMap map{c, moved, stretch};
      std::vector<Vec3> points = interior_points(c, 10, 59);
      points.push_back(Vec3(0.3, -0.2, 2.5));  // outside
      for (const Vec3& x : points) {
        Eigen::Matrix3d jacobian;
        map(x, &jacobian);
        for (int a = 0; a < 3; ++a) {
          Vec3 e = Vec3::Zero();
          e[a] = h;
          const Vec3 fd = (map(x + e) - map(x - e)) / (2 * h);
          EXPECT_LT((jacobian.col(a) - fd).norm(), 1e-6 * std::max(1.0, jacobian.norm())) << name << x.transpose();
        }
      }
    }
  }
}

// With the extension, F is continuous across the cage surface: points 1e-10 inside and outside a
// face map within 1e-9 (relative to the cage's size) under a non-rigid edit.
TEST(GreenCoordinates, ContinuousAcrossTheCageSurface) {
  std::mt19937 rng(61);
  double worst = 0, raw_jump = 0;
  for (const auto& [name, c] : test_cages()) {
    const Cage moved = edited(c, 67);
    for (bool stretch : {true, false}) {
      const GreenMap map{c, moved, stretch};
      for (std::size_t j = 0; j < c.t(); ++j) {
        const Vec3 q = point_on_triangle(c, j, rng), n = c.normal(j);
        const double jump = (map(q + 1e-10 * n) - map(q - 1e-10 * n)).norm();
        EXPECT_LT(jump, 1e-9 * 2.0) << name << " face " << j;
        worst = std::max(worst, jump);
        // Without the extension the raw integrals jump by the face's hat functions there.
        const double x_out[3] = {q.x() + 1e-10 * n.x(), q.y() + 1e-10 * n.y(), q.z() + 1e-10 * n.z()};
        std::vector<double> phi(c.m()), psi(c.t());
        green_integrals(x_out, c.view(), phi.data(), psi.data(), nullptr, nullptr);
        raw_jump = std::max(raw_jump, 1.0 - sum(phi));
      }
    }
  }
  std::printf("[green] jump of F across the cage surface (+-1e-10 along a face normal): max %.3g; "
              "sum phi of the raw integrals jumps by %.3g\n",
              worst, raw_jump);
  EXPECT_NEAR(raw_jump, 1.0, 1e-9);
}

// Quasi-conformality (Lipman et al. 2008, §3): the mean angle change of small triangles inside the
// cube under a fixed non-rigid cage edit, GC against trilinear interpolation of the same corners.
TEST(GreenCoordinates, AngleDistortionOfSmallTriangles) {
  const Cage c = cube();
  // The edit: the top face turned by 35 degrees and widened by 1.4, the corner (1,1,1) pulled out.
  const Cage moved = deformed(c, [](const Vec3& p) {
    if (p.z() < 0) return p;
    const double a = 35.0 * kPi / 180.0;
    Vec3 q(1.4 * (std::cos(a) * p.x() - std::sin(a) * p.y()), 1.4 * (std::sin(a) * p.x() + std::cos(a) * p.y()),
           p.z());
    if (p.x() > 0 && p.y() > 0) q += Vec3(0.3, 0.3, 0.5);
    return q;
  });
  auto trilinear = [&](const Vec3& x) {
    Vec3 r = Vec3::Zero();
    for (int i = 0; i < 8; ++i) {
      double w = 1;
      for (int a = 0; a < 3; ++a) w *= (i >> a) & 1 ? (1 + x[a]) / 2 : (1 - x[a]) / 2;
      r += w * moved.point(i);
    }
    return r;
  };
  const GreenMap green{c, moved, true}, green_unit{c, moved, false};
  auto angles = [](const Vec3& a, const Vec3& b, const Vec3& c3) {
    return Vec3(angle_between(b - a, c3 - a), angle_between(c3 - b, a - b), angle_between(a - c3, b - c3));
  };
  double distortion[3] = {0, 0, 0};
  int triangles = 0;
  const double spacing = 0.05;
  // Equilateral triangles of side 0.05 in three planes through the cage.
  for (int plane = 0; plane < 3; ++plane)
    for (int i = -12; i < 12; ++i)
      for (int j = -12; j < 12; ++j) {
        const Vec3 base(i * spacing + (j % 2) * spacing / 2, j * spacing * std::sqrt(3.0) / 2, -0.5 + 0.5 * plane);
        const Vec3 tri[3] = {base, base + Vec3(spacing, 0, 0),
                             base + Vec3(spacing / 2, spacing * std::sqrt(3.0) / 2, 0)};
        const Vec3 rest = angles(tri[0], tri[1], tri[2]);
        const Vec3 g = angles(green(tri[0]), green(tri[1]), green(tri[2]));
        const Vec3 g1 = angles(green_unit(tri[0]), green_unit(tri[1]), green_unit(tri[2]));
        const Vec3 t = angles(trilinear(tri[0]), trilinear(tri[1]), trilinear(tri[2]));
        distortion[0] += (g - rest).cwiseAbs().sum() / 3;
        distortion[1] += (g1 - rest).cwiseAbs().sum() / 3;
        distortion[2] += (t - rest).cwiseAbs().sum() / 3;
        ++triangles;
      }
  const double to_degrees = 180.0 / kPi / triangles;
  std::printf("[green] mean angle change of %d small triangles: GC %.3f deg, GC with s = 1 %.3f deg, "
              "trilinear %.3f deg\n",
              triangles, distortion[0] * to_degrees, distortion[1] * to_degrees, distortion[2] * to_degrees);
  EXPECT_LT(distortion[0], distortion[2]);
}

// The SIMD rows (green_rows.cpp) against the single-point code: the same closed form, so they agree
// to a few ulps of the coordinates' scale, also 1e-12 from faces, edges and vertices, on them, in
// faces' planes and outside (where the rows hand over to the single-point guards and extension).
TEST(GreenCoordinates, RowsMatchSinglePoints) {
  for (const NamedCage& named : test_cages()) {
    const Cage& c = named.cage;
    std::mt19937 rng(91);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<Vec3> points = interior_points(c, 200, 5);
    for (std::size_t j = 0; j < c.t(); ++j) {
      const Vec3 on = point_on_triangle(c, j, rng);
      points.push_back(on);
      for (double h : {1e-3, 1e-6, 1e-9, 1e-12}) {
        points.push_back(on + h * c.normal(j));
        points.push_back(on - h * c.normal(j));
      }
      const Vec3 a = c.corner(j, 0), b = c.corner(j, 1);
      const Vec3 mid = a + u(rng) * (b - a);
      points.push_back(mid);
      points.push_back(a);
      for (double h : {1e-4, 1e-9, 1e-12}) {
        points.push_back(mid - h * (c.normal(j) + (mid - a).cross(c.normal(j)).normalized()));
        points.push_back(a + h * Vec3(u(rng), u(rng), u(rng)));
      }
      points.push_back(a + 2.0 * (b - a));          // on the edge's line beyond its end
      points.push_back(on + (b - a) * 3.0);         // in the face's plane, off the face
      points.push_back(3.0 * on);                   // outside
      points.push_back(1e6 * on);                   // far outside
    }
    const std::size_t n = points.size(), w = c.m() + c.t();
    std::vector<double> xs;
    for (const Vec3& p : points) xs.insert(xs.end(), {p.x(), p.y(), p.z()});
    const GreenCageTables tables = green_cage_tables(c.view());
    for (std::size_t chunk : {std::size_t(1), std::size_t(3), std::size_t(64), n}) {
      std::vector<double> rows(n * w, -7.0);
      for (std::size_t lo = 0; lo < n; lo += chunk)
        green_coordinate_rows(xs.data() + 3 * lo, std::min(chunk, n - lo), c.view(), tables, rows.data() + lo * w);
      double worst = 0;
      for (std::size_t i = 0; i < n; ++i) {
        const Coordinates k = coordinates(c, points[i]);
        double scale = 1.0;
        for (double v : k.phi) scale = std::max(scale, std::abs(v));
        for (double v : k.psi) scale = std::max(scale, std::abs(v));
        for (std::size_t a = 0; a < c.m(); ++a) worst = std::max(worst, std::abs(rows[i * w + a] - k.phi[a]) / scale);
        for (std::size_t a = 0; a < c.t(); ++a)
          worst = std::max(worst, std::abs(rows[i * w + c.m() + a] - k.psi[a]) / scale);
      }
      EXPECT_LT(worst, 1e-13) << named.name << ", chunks of " << chunk;
    }
  }
}
