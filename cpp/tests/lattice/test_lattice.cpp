#include "lattice/lattice_fixtures.hpp"

#include <gtest/gtest.h>

#include <random>

using namespace deformkit;
using namespace deformkit::test;

namespace {

const BasisKind kAllKinds[] = {BasisKind::Bernstein,     BasisKind::BezierBlocks,    BasisKind::UniformBSpline,
                               BasisKind::BlenderLinear, BasisKind::BlenderCardinal, BasisKind::BlenderCatmullRom,
                               BasisKind::BlenderBSpline};

int count_for(BasisKind k) { return k == BasisKind::Bernstein ? 6 : k == BasisKind::BezierBlocks ? 7 : 5; }

}  // namespace

// Every basis is a partition of unity with linear precision on its rest grid: the reason a rest
// lattice is the identity (docs/math/lattice.md).
TEST(LatticeBasis, PartitionOfUnityAndDerivatives) {
  for (BasisKind kind : kAllKinds) {
    const AxisBasis a = AxisBasis::make(kind, count_for(kind), "resolution");
    for (double s = -0.3; s <= 1.3; s += 0.0137) {
      const AxisSpan span = a.locate(s, is_blender(kind) ? Outside::Clamp : Outside::Extrapolate);
      double w[kMaxAxisWidth], dw[kMaxAxisWidth];
      int idx[kMaxAxisWidth];
      a.evaluate(span, w, dw, idx);
      double sum = 0, dsum = 0, moment = 0;
      for (int k = 0; k < a.width(); ++k) {
        sum += w[k];
        dsum += dw[k];
        moment += w[k] * a.rest_coordinate(idx[k]);
      }
      EXPECT_NEAR(sum, 1.0, 1e-13) << int(kind) << " s=" << s;
      EXPECT_NEAR(dsum, 0.0, 1e-11) << int(kind) << " s=" << s;
      // Linear precision inside the domain for the polynomial bases (Blender's cardinal is not).
      const bool precise = kind == BasisKind::Bernstein || kind == BasisKind::BezierBlocks ||
                           kind == BasisKind::UniformBSpline || kind == BasisKind::BlenderLinear;
      if (precise && span.inside) EXPECT_NEAR(moment, s, 1e-13) << int(kind) << " s=" << s;
      // The derivative against central differences of the weights, away from piece boundaries.
      const double h = 1e-6;
      const AxisSpan lo = a.locate(s - h, Outside::Extrapolate), hi = a.locate(s + h, Outside::Extrapolate);
      if (lo.piece != hi.piece || span.frozen || !span.inside) continue;
      double wl[kMaxAxisWidth], wh[kMaxAxisWidth];
      int il[kMaxAxisWidth];
      a.evaluate(lo, wl, nullptr, il);
      a.evaluate(hi, wh, nullptr, il);
      for (int k = 0; k < a.width(); ++k) EXPECT_NEAR(dw[k], (wh[k] - wl[k]) / (2 * h), 1e-6) << int(kind);
    }
  }
}

TEST(LatticeBasis, BernsteinMatchesDeCasteljau) {
  for (int degree = 1; degree <= 15; ++degree)
    for (double t : {-0.2, 0.0, 0.31, 0.5, 0.97, 1.0, 1.1}) {
      double w[kMaxAxisWidth], dw[kMaxAxisWidth];
      bernstein_basis(degree, t, w, dw);
      for (int i = 0; i <= degree; ++i) {
        // De Casteljau on the unit vector e_i evaluates B_i at t independently of the binomials.
        double c[kMaxAxisWidth] = {};
        c[i] = 1.0;
        for (int r = 1; r <= degree; ++r)
          for (int k = 0; k <= degree - r; ++k) c[k] = (1 - t) * c[k] + t * c[k + 1];
        EXPECT_NEAR(w[i], c[0], 1e-12) << degree << " " << i << " " << t;
      }
    }
}

TEST(LatticeBox, DegenerateEdgesAreRejected) {
  Mat3 e = Mat3::Identity();
  e.col(2) = e.col(0) + e.col(1);  // coplanar
  EXPECT_THROW(LatticeBox::from_edges(Vec3::Zero(), e), std::invalid_argument);
  EXPECT_THROW(LatticeBox::from_edges(Vec3::Zero(), Mat3::Zero()), std::invalid_argument);
  // Size does not matter, only flatness.
  EXPECT_NO_THROW(LatticeBox::from_edges(Vec3::Zero(), 1e-6 * Mat3::Identity()));
}

// The cell-sorted SIMD kernel (deform) against the scalar weights (x + strength W (P - R)), for
// every basis, both precisions and every SIMD tail length.
TEST(Lattice, KernelMatchesScalarWeights) {
  for (BasisKind kind : kAllKinds) {
    const int c = count_for(kind);
    std::shared_ptr<BoxLattice> lat;
    if (kind == BasisKind::Bernstein) lat = std::make_shared<FFD>(skewed_box(), std::array<int, 3>{5, 2, 3});
    else if (kind == BasisKind::BezierBlocks) lat = std::make_shared<BezierFFD>(skewed_box(), std::array<int, 3>{2, 1, 2});
    else if (kind == BasisKind::UniformBSpline)
      lat = std::make_shared<BSplineLattice>(skewed_box(), std::array<int, 3>{c, 4, 6});
    else
      lat = std::make_shared<BlenderLattice>(skewed_box(), std::array<int, 3>{c, 3, 1},
                                             std::array<BasisKind, 3>{kind, BasisKind::BlenderLinear, kind},
                                             Outside::Clamp, 0.7);
    perturb(*lat, 7, 0.1);
    for (std::size_t n : {1u, 3u, 7u, 17u, 33u, 1000u}) {
      const auto pts = random_points(n, -1.0, 2.0, unsigned(n));
      const LatticeBinding b = lat->bind(pts.data(), n);
      const SparseWeights w = lat->weights_matrix(b);
      std::vector<double> out(3 * n);
      lat->deform(pts.data(), out.data(), n);
      std::vector<float> ptsf(pts.begin(), pts.end()), outf(3 * n);
      lat->deform(ptsf.data(), outf.data(), n);
      for (std::size_t i = 0; i < n; ++i)
        for (int a = 0; a < 3; ++a) {
          double expect = pts[3 * i + a];
          for (auto e = w.indptr[i]; e < w.indptr[i + 1]; ++e)
            expect += lat->strength() * w.values[e] *
                      (lat->control_points()[3 * w.indices[e] + a] - lat->rest_control_points()[3 * w.indices[e] + a]);
          EXPECT_NEAR(out[3 * i + a], expect, 1e-12) << int(kind) << " n=" << n;
          EXPECT_NEAR(outf[3 * i + a], expect, 2e-6) << int(kind) << " n=" << n;
        }
    }
  }
}

TEST(Lattice, JacobianMatchesFiniteDifferences) {
  auto lat = std::make_shared<BSplineLattice>(skewed_box(), std::array<int, 3>{5, 6, 4});
  perturb(*lat, 3, 0.08);
  const auto pts = random_points(300, -0.2, 1.2, 9);
  for (std::size_t i = 0; i < 300; ++i) {
    const Vec3 p(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
    EXPECT_LT((jacobian_one(*lat, p) - finite_difference_jacobian(*lat, p)).cwiseAbs().maxCoeff(), 2e-5);
  }
}

// Extended FFD: invert then evaluate the rest lattice gives the point back (docs/math/lattice.md, "Extended FFD").
TEST(ExtendedFFD, NewtonRoundTripOnACylinder) {
  const auto grid = ExtendedFFD::cylinder_grid(1.0, 2.0, {1, 4, 2}, Vec3(0.5, 0, 0), 0);
  const ExtendedFFD effd({4, 13, 7}, grid, 1.0, NewtonSettings{});
  EXPECT_EQ(effd.handle_count(), 7 + 3 * 12 * 7);  // the axis row is one handle per height; the seam merges
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> pts;
  for (int i = 0; i < 500; ++i) {
    const double r = 0.95 * std::sqrt(u(rng)), a = 2 * M_PI * u(rng), h = 1.9 * (u(rng) - 0.5);
    pts.insert(pts.end(), {0.5 + h, r * std::cos(a), r * std::sin(a)});
  }
  const LatticeBinding b = effd.bind(pts.data(), 500);
  for (std::size_t i = 0; i < 500; ++i) EXPECT_EQ(b.status[i], std::uint8_t(PointStatus::Inside)) << i;
  // Round trip through the weights: sum w R at the found coordinates is the point.
  const SparseWeights w = effd.weights_matrix(b);
  for (std::size_t i = 0; i < 500; ++i)
    for (int a = 0; a < 3; ++a) {
      double x = 0;
      for (auto e = w.indptr[i]; e < w.indptr[i + 1]; ++e) x += w.values[e] * grid[3 * w.indices[e] + a];
      EXPECT_NEAR(x, pts[3 * i + a], 1e-9);
    }
}

// The lattice's weights are the core's weight table: its generic product (what cages and RBF
// will use) reproduces the lattice's own kernel, and the bound path (BoundDeformer) agrees with
// deform() bit for bit, weights included.
TEST(Lattice, WeightTableProductAndBoundPathMatchDeform) {
  auto lat = std::make_shared<BlenderLattice>(skewed_box(), std::array<int, 3>{4, 3, 5},
                                              std::array<BasisKind, 3>{BasisKind::BlenderBSpline,
                                                                       BasisKind::BlenderCardinal,
                                                                       BasisKind::BlenderLinear},
                                              Outside::Clamp, 0.8);
  perturb(*lat, 11, 0.1);
  const std::size_t n = 30000;
  const auto pts = random_points(n, -0.5, 1.8, 12);
  const LatticeBinding b = lat->bind(pts.data(), n);
  const WeightTable w = lat->weights_matrix(b);
  w.require_valid(lat->control_count(), "weights");
  std::vector<double> offset(lat->control_points().size());
  for (std::size_t i = 0; i < offset.size(); ++i)
    offset[i] = lat->strength() * (lat->control_points()[i] - lat->rest_control_points()[i]);
  std::vector<double> moved(3 * n), out(3 * n);
  apply_weight_table(w, offset.data(), 3, moved.data());
  lat->deform(pts.data(), out.data(), n);
  for (std::size_t i = 0; i < 3 * n; ++i) ASSERT_NEAR(out[i], pts[i] + moved[i], 1e-12) << i / 3;

  std::vector<double> weights(n);
  for (std::size_t i = 0; i < n; ++i) weights[i] = double(i % 9) / 8.0;
  lat->set_weights(weights);
  std::vector<double> bound(3 * n), unbound(3 * n);
  lat->deform_bound(b, bound.data());
  lat->deform(pts.data(), unbound.data(), n);
  EXPECT_EQ(bound, unbound);
  const std::vector<float> ptsf(pts.begin(), pts.end());
  std::vector<float> boundf(3 * n), unboundf(3 * n);
  lat->deform_bound(lat->bind(ptsf.data(), n), boundf.data());
  lat->deform(ptsf.data(), unboundf.data(), n);
  EXPECT_EQ(boundf, unboundf);
  // displacement_bound, one pass: w (F(x) - x) = w W (strength (P - R)), read off the weight table.
  std::vector<double> disp(3 * n);
  lat->displacement_bound(b, disp.data());
  for (std::size_t i = 0; i < 3 * n; ++i) ASSERT_NEAR(disp[i], weights[i / 3] * moved[i], 1e-12) << i / 3;
}

TEST(Lattice, ABindingOfAnotherFamilyIsRefused) {
  const FFD lat(skewed_box(), {2, 2, 2});
  PointBinding other;
  other.point_count = 1;
  std::vector<double> out(3);
  try {
    lat.deform_bound(other, out.data());
    ADD_FAILURE() << "a foreign binding was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "binding: was not made by a lattice; bind the points to this lattice");
  }
}

// Far outside, the gain sum |w_ijk| is the product over the axes of sum |w_axis|: for Bernstein
// weights of degree d at s = 1 + delta, (|1 - s| + |s|)^d = (1 + 2 delta)^d; 1 inside the box.
TEST(Lattice, ExtrapolationGainIsTheClosedForm) {
  const FFD lat(LatticeBox::from_edges(Vec3::Zero(), Mat3::Identity()), {2, 3, 1}, Outside::Extrapolate);
  EXPECT_EQ(lat.extrapolation_gain(Vec3(0.3, 0.9, 0.5)), 1.0);
  for (double delta : {0.5, 3.0, 40.0}) {
    const Vec3 s(1.0 + delta, -delta, 1.0 + 2.0 * delta);
    const double expected = std::pow(1 + 2 * delta, 2) * std::pow(1 + 2 * delta, 3) * (1 + 4 * delta);
    EXPECT_NEAR(lat.extrapolation_gain(s), expected, 1e-13 * expected) << delta;
  }
}
