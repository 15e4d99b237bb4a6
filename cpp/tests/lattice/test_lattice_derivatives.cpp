// The lattice's derivative paths in SIMD lanes (jacobian, transform_normals, volume_ratio) against
// the per-point formulas (reference_jacobian, normal_direction, scaled_determinant), which are
// themselves checked against finite differences of deform: every basis, outside policy, weight
// and vector tail; rows the lanes hand back; float32 normals against float64.
#include "lattice/lattice_fixtures.hpp"

#include "core/scale_free.hpp"

#include <gtest/gtest.h>

#include <functional>
#include <memory>
#include <random>

using namespace deformkit;
using namespace deformkit::test;

namespace {

struct Case {
  std::string name;
  std::function<std::unique_ptr<ControlLattice>(Outside)> make;
  bool extrapolates;
};

std::vector<Case> cases() {
  const LatticeBox box = skewed_box();
  auto blender = [box](std::array<int, 3> res, std::array<BasisKind, 3> kinds) {
    return [=](Outside o) { return std::make_unique<BlenderLattice>(box, res, kinds, o, 0.8); };
  };
  const BasisKind B = BasisKind::BlenderBSpline, L = BasisKind::BlenderLinear, C = BasisKind::BlenderCardinal,
                  R = BasisKind::BlenderCatmullRom;
  return {
      {"ffd_3_2_4", [box](Outside o) { return std::make_unique<FFD>(box, std::array<int, 3>{3, 2, 4}, o, 1.0); }, true},
      {"ffd_3", [box](Outside o) { return std::make_unique<FFD>(box, std::array<int, 3>{3, 3, 3}, o, 1.3); }, true},
      {"bezier_2_1_3", [box](Outside o) { return std::make_unique<BezierFFD>(box, std::array<int, 3>{2, 1, 3}, o); }, true},
      {"bspline_5_4_6", [box](Outside o) { return std::make_unique<BSplineLattice>(box, std::array<int, 3>{5, 4, 6}, o); }, true},
      {"blender_bspline", blender({4, 5, 3}, {B, B, B}), false},
      {"blender_mixed", blender({3, 4, 5}, {L, C, R}), false},
      {"blender_flat_axis", blender({4, 1, 3}, {B, L, C}), false},
  };
}

Vec3 at(const std::vector<double>& v, std::size_t i) { return Vec3(v[3 * i], v[3 * i + 1], v[3 * i + 2]); }

// Points over the box and around it (box coordinates -0.4 .. 1.4), so that clamped and
// extrapolated rows are among them.
std::vector<double> around_box(std::size_t n, unsigned seed) {
  const LatticeBox box = skewed_box();
  auto s = random_points(n, -0.4, 1.4, seed);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 p = box.point(at(s, i));
    for (int a = 0; a < 3; ++a) s[3 * i + a] = p[a];
  }
  return s;
}

Mat3 reference(const ControlLattice& lat, const Vec3& p, double w) {
  Mat3 j;
  double jac[9];
  lat.reference_jacobian(p.data(), jac, 1);
  for (int e = 0; e < 9; ++e) j(e / 3, e % 3) = jac[e];
  return (1 - w) * Mat3::Identity() + w * j;
}

}  // namespace

TEST(LatticeDerivatives, TheReferenceIsTheDerivativeOfDeform) {
  for (const auto& c : cases()) {
    auto lat = c.make(Outside::Clamp);
    perturb(*lat, 3, 0.08);
    const std::size_t n = 60;
    const auto pts = around_box(n, 4);
    std::size_t checked = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3 p = at(pts, i);
      const Mat3 fd = finite_difference_jacobian(*lat, p, 1e-6);
      const Mat3 j = reference(*lat, p, 1.0);
      // Skip rows within a step of a piece boundary or the box, where the map has a kink.
      if ((fd - j).cwiseAbs().maxCoeff() > 1e-2) continue;
      ASSERT_LT((fd - j).cwiseAbs().maxCoeff(), 1e-6) << c.name << " row " << i;
      ++checked;
    }
    EXPECT_GE(checked, n * 9 / 10) << c.name;
  }
}

TEST(LatticeDerivatives, LanesMatchThePerPointFormulas) {
  for (const auto& c : cases())
    for (Outside outside : {Outside::Clamp, Outside::Unchanged, Outside::Extrapolate}) {
      if (outside == Outside::Extrapolate && !c.extrapolates) continue;
      for (bool weighted : {false, true})
        for (std::size_t n : {1u, 7u, 8u, 13u, 2000u}) {
          auto lat = c.make(outside);
          perturb(*lat, 5 + unsigned(n), 0.1);
          const auto pts = around_box(n, 6 + unsigned(n));
          const auto nrm = random_points(n, -1.0, 1.0, 7 + unsigned(n));
          std::vector<double> w(n);
          for (std::size_t i = 0; i < n; ++i) w[i] = double((i * 37) % 11) / 10.0;
          if (weighted) lat->set_weights(w);
          std::vector<double> jac(9 * n), normals(3 * n), det(n);
          lat->jacobian(pts.data(), jac.data(), n);
          transform_normals(*lat, pts.data(), nrm.data(), normals.data(), n);
          volume_ratio(*lat, pts.data(), det.data(), n);
          for (std::size_t i = 0; i < n; ++i) {
            const Mat3 j = reference(*lat, at(pts, i), weighted ? w[i] : 1.0);
            const double scale = 1.0 + j.cwiseAbs().maxCoeff();
            for (int e = 0; e < 9; ++e)
              ASSERT_NEAR(jac[9 * i + e], j(e / 3, e % 3), 1e-13 * scale) << c.name << " row " << i;
            ASSERT_LT((at(normals, i) - normal_direction(j, at(nrm, i))).norm(), 1e-12) << c.name << " row " << i;
            ASSERT_NEAR(det[i], scaled_determinant(j), 1e-13 * scale * scale * scale) << c.name << " row " << i;
          }
        }
    }
}

TEST(LatticeDerivatives, RowsTheLanesHandBackAreThePerPointPaths) {
  // Zero, tiny (handed to the scale-free per-point path) and huge normals among ordinary ones.
  FFD ffd(skewed_box(), {3, 3, 3}, Outside::Clamp);
  perturb(ffd, 14, 0.1);
  const std::size_t n = 6;
  const auto pts = around_box(n, 15);
  const std::vector<double> nrm = {0, 0, 1, 0, 0, 0, 1e-300, 0, 2e-300, 3e300, -1e300, 1e300, 0, 1e-310, 0, 1, 2, 3};
  std::vector<double> out(3 * n);
  transform_normals(ffd, pts.data(), nrm.data(), out.data(), n);
  for (std::size_t i = 0; i < n; ++i) {
    const Mat3 j = reference(ffd, at(pts, i), 1.0);
    ASSERT_LT((at(out, i) - normal_direction(j, at(nrm, i))).norm(), 1e-13) << "row " << i;
    Vec3 alone;  // a row alone gives what it gives among the others
    transform_normals(ffd, pts.data() + 3 * i, nrm.data() + 3 * i, alone.data(), 1);
    ASSERT_EQ(alone, at(out, i)) << "row " << i;
    if (i != 1) ASSERT_NEAR(at(out, i).norm(), 1.0, 1e-15) << "row " << i;
  }
  EXPECT_EQ(at(out, 1), Vec3::Zero());  // a zero normal stays zero
}

TEST(LatticeDerivatives, AFlattenedLatticeHasNoVolume) {
  // Every control point pressed onto the plane z = 0.4: F_z = 0.4 inside, so det J = 0 there
  // up to rounding, and a normal along z stays along z.
  FFD ffd(LatticeBox::from_edges(Vec3::Zero(), Mat3::Identity()), {2, 2, 2}, Outside::Clamp);
  auto grid = ffd.control_points();
  for (std::size_t i = 2; i < grid.size(); i += 3) grid[i] = 0.4;
  ffd.set_control_points(grid);
  const std::size_t n = 100;
  const auto pts = random_points(n, 0.0, 1.0, 16);
  std::vector<double> nrm(3 * n, 0.0), out(3 * n), det(n);
  for (std::size_t i = 0; i < n; ++i) nrm[3 * i + 2] = 1.0;
  volume_ratio(ffd, pts.data(), det.data(), n);
  transform_normals(ffd, pts.data(), nrm.data(), out.data(), n);
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_LT(std::abs(det[i]), 1e-14) << "row " << i;
    ASSERT_NEAR(std::abs(out[3 * i + 2]), 1.0, 1e-12) << "row " << i;
  }
}

TEST(LatticeDerivatives, Float32NormalsMatchFloat64) {
  for (const auto& c : cases()) {
    auto lat = c.make(Outside::Clamp);
    perturb(*lat, 9, 0.08);
    const std::size_t n = 3001;
    const auto pts = around_box(n, 10), nrm = random_points(n, -1.0, 1.0, 11);
    std::vector<float> p32(pts.begin(), pts.end()), n32(nrm.begin(), nrm.end()), o32(3 * n);
    std::vector<double> p64(p32.begin(), p32.end()), n64(n32.begin(), n32.end()), o64(3 * n);
    transform_normals(*lat, p32.data(), n32.data(), o32.data(), n);
    transform_normals(*lat, p64.data(), n64.data(), o64.data(), n);
    for (std::size_t i = 0; i < 3 * n; ++i) ASSERT_NEAR(o32[i], o64[i], 2e-5) << c.name << " entry " << i;
  }
}

TEST(LatticeDerivatives, BadRowsAreStillNamed) {
  // A lattice far from the origin: a point beyond it overflows its lattice coordinates.
  FFD ffd(LatticeBox::from_edges(Vec3(-1e308, 0, 0), Mat3::Identity()), {3, 3, 3}, Outside::Clamp);
  perturb(ffd, 12, 0.1);
  std::vector<double> pts(30, 0.5), nrm(30, 1.0), out(30), det(10);
  nrm[13] = NAN;
  try {
    transform_normals(ffd, pts.data(), nrm.data(), out.data(), 10);
    ADD_FAILURE() << "a NaN normal was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("normals: row 4", 0), 0u) << e.what();
  }
  nrm[13] = 1.0;
  pts[18] = 1e308;  // finite, but its lattice coordinates overflow
  for (int what = 0; what < 3; ++what) {
    try {
      if (what == 0) transform_normals(ffd, pts.data(), nrm.data(), out.data(), 10);
      if (what == 1) volume_ratio(ffd, pts.data(), det.data(), 10);
      if (what == 2) ffd.jacobian(pts.data(), std::vector<double>(90).data(), 10);
      ADD_FAILURE() << "an overflowing row was accepted (" << what << ")";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("row 6"), std::string::npos) << e.what();
    }
  }
}

// The SIMD placement (parameters, status, cell, local coordinate) is the per-point formulas bit
// for bit: LatticeBox::coordinates and AxisBasis::locate, on points that include the faces and
// the piece boundaries exactly.
TEST(LatticePlacement, LanesAreThePerPointFormulasBitForBit) {
  const LatticeBox box = skewed_box();
  for (const auto& c : cases())
    for (Outside outside : {Outside::Clamp, Outside::Unchanged, Outside::Extrapolate}) {
      if (outside == Outside::Extrapolate && !c.extrapolates) continue;
      auto lat = c.make(outside);
      const std::size_t n = 3000;
      auto pts = around_box(n, 17);
      for (std::size_t i = 0; i < 600; ++i) {  // box coordinates on the grid of sixths and eighths
        const Vec3 s(double(i % 9) / 8.0 - 0.125, double((i / 9) % 7) / 6.0, double((i / 63) % 9) / 8.0);
        const Vec3 x = box.point(s);
        for (int a = 0; a < 3; ++a) pts[3 * i + a] = x[a];
      }
      const LatticeBinding b = lat->bind(pts.data(), n);
      std::vector<std::size_t> slot(n);
      for (std::size_t i = 0; i < n; ++i) slot[b.order[i]] = i;
      for (std::size_t i = 0; i < n; ++i) {
        const Vec3 s = box.coordinates(at(pts, i));
        bool inside = true;
        for (int a = 0; a < 3; ++a) {
          ASSERT_EQ(b.parameters[3 * i + a], s[a]) << c.name << " row " << i;
          const AxisSpan span = lat->axes()[a].locate(s[a], outside);
          inside = inside && span.inside;
          const bool moves = b.status[i] == 0 || outside != Outside::Unchanged;
          ASSERT_EQ(b.sorted_d[a * n + slot[i]], moves ? span.t : 0.0) << c.name << " row " << i << " axis " << a;
        }
        ASSERT_EQ(b.status[i], inside ? 0 : 1) << c.name << " row " << i;
      }
    }
}

// Found by the out= tests: volume ratios written just before the points (n values, then 3n) do not
// overlap them, and must come from the same path, bit for bit, as into a separate array.
TEST(LatticeDerivatives, AnOutputBesideTheInputsTakesTheSamePath) {
  FFD ffd(skewed_box(), {3, 3, 3}, Outside::Clamp);
  perturb(ffd, 18, 0.1);
  const std::size_t n = 1001;
  const auto pts = around_box(n, 19);
  std::vector<double> apart(n), together(4 * n);
  std::copy(pts.begin(), pts.end(), together.begin() + n);
  volume_ratio(ffd, pts.data(), apart.data(), n);
  volume_ratio(ffd, together.data() + n, together.data(), n);
  for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(together[i], apart[i]) << "row " << i;
}
