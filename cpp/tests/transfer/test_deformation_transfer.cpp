// Deformation transfer (same connectivity) against invariants: the rest pose transfers to the
// target rest, a source equal to the target reproduces every pose, an affine pose transfers as the
// same affine map of the target, rotating the whole setup rotates the result, several poses at
// once equal one at a time, and bad input is refused by name.
#include "deformkit/transfer/deformation_transfer.hpp"
#include "test_util.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

using namespace deformkit;
using namespace deformkit::test;

namespace {

// A bumpy (n x n) grid of quads: an open surface with one connected part.
struct Grid {
  std::vector<double> points;
  std::vector<int> quads;
};

Grid grid(int n) {
  Grid g;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = double(i) / (n - 1), y = double(j) / (n - 1);
      g.points.insert(g.points.end(), {x, y, 0.1 * std::sin(3 * x) * std::cos(2 * y)});
    }
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) g.quads.insert(g.quads.end(), {j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i});
  return g;
}

PolygonMesh mesh(const std::vector<double>& points, const std::vector<int>& quads) {
  return PolygonMesh(points.data(), points.size() / 3, quads.data(), quads.size() / 4, 4);
}

std::vector<double> mapped(const std::vector<double>& p, Vec3 (*f)(const Vec3&)) {
  std::vector<double> out(p.size());
  for (std::size_t i = 0; i < p.size() / 3; ++i) {
    const Vec3 q = f(Vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]));
    for (int a = 0; a < 3; ++a) out[3 * i + a] = q[a];
  }
  return out;
}

Vec3 other_character(const Vec3& p) { return Vec3(1.4 * p.x() + 0.2 * p.y() * p.y(), 0.8 * p.y(), p.z() + 0.3 * p.x() * p.y()); }
Vec3 bent(const Vec3& p) {
  const double a = 0.8 * p.x();
  return Vec3(std::sin(a) / 0.8, p.y() + 0.1 * p.x(), p.z() + (1 - std::cos(a)) / 0.8);
}

double largest_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double worst = 0;
  for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(a[i] - b[i]));
  return worst;
}

std::vector<double> transferred(const DeformationTransfer& dt, const std::vector<double>& pose) {
  std::vector<double> out(pose.size());
  dt.transfer(pose.data(), 1, out.data());
  return out;
}

}  // namespace

TEST(DeformationTransfer, TheRestPoseTransfersToTheTargetRest) {
  const Grid g = grid(12);
  const std::vector<double> target = mapped(g.points, other_character);
  const DeformationTransfer dt(mesh(g.points, g.quads), target);
  EXPECT_LT(largest_difference(transferred(dt, g.points), target), 1e-12);
  EXPECT_EQ(dt.anchors(), std::vector<int>{0});
}

TEST(DeformationTransfer, ASourceEqualToTheTargetReproducesEveryPose) {
  const Grid g = grid(12);
  const DeformationTransfer dt(mesh(g.points, g.quads), g.points);
  const std::vector<double> pose = mapped(g.points, bent);
  EXPECT_LT(largest_difference(transferred(dt, pose), pose), 1e-11);
}

// The largest |(x'_i - x'_0) - L (t_i - t_0)| over the target: an affine map with linear part L, up
// to the translation the anchor chooses.
double affine_defect(const std::vector<double>& out, const std::vector<double>& target, const Eigen::Matrix3d& l) {
  double worst = 0;
  for (std::size_t i = 1; i < out.size() / 3; ++i) {
    const Vec3 got(out[3 * i] - out[0], out[3 * i + 1] - out[1], out[3 * i + 2] - out[2]);
    const Vec3 edge(target[3 * i] - target[0], target[3 * i + 1] - target[1], target[3 * i + 2] - target[2]);
    worst = std::max(worst, (got - l * edge).norm());
  }
  return worst;
}

std::vector<double> moved_by(const std::vector<double>& p, const Eigen::Matrix3d& l, const Vec3& b) {
  std::vector<double> out(p.size());
  for (std::size_t i = 0; i < p.size() / 3; ++i) {
    const Vec3 q = l * Vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]) + b;
    for (int a = 0; a < 3; ++a) out[3 * i + a] = q[a];
  }
  return out;
}

// Sumner's frames carry an affine pose A exactly as A where the fourth vertex n / sqrt(|n|) moves
// by A: for a similarity (the normal scales as the edges), on any target; for any affine map, on
// a target whose triangles lie in the source's planes (its tangential part is all the fit uses).
// Otherwise the normal direction's n / sqrt(|n|) is not A n / sqrt(|n|), and a target triangle
// tilted from its source partner sees some of it (docs/math/transfer.md, "What transfers exactly").
TEST(DeformationTransfer, AffinePosesTransferAsTheSameAffineMap) {
  const Grid g = grid(10);
  const Eigen::Matrix3d similarity = 1.3 * Eigen::AngleAxisd(0.6, Vec3(1, -1, 2).normalized()).toRotationMatrix();
  const Eigen::Matrix3d affine = random_frame(5).linear;
  const std::vector<double> other = mapped(g.points, other_character);
  const DeformationTransfer to_other(mesh(g.points, g.quads), other);
  EXPECT_LT(affine_defect(transferred(to_other, moved_by(g.points, similarity, Vec3(1, 2, 3))), other, similarity), 1e-11);
  const std::vector<double> parallel = moved_by(g.points, 0.7 * Eigen::Matrix3d::Identity(), Vec3(2, 0, 1));
  const DeformationTransfer to_parallel(mesh(g.points, g.quads), parallel);
  EXPECT_LT(affine_defect(transferred(to_parallel, moved_by(g.points, affine, Vec3(1, 2, 3))), parallel, affine), 1e-11);
  // A tilted target does see the normal direction's difference: the claim is not vacuous.
  EXPECT_GT(affine_defect(transferred(to_other, moved_by(g.points, affine, Vec3(1, 2, 3))), other, affine), 1e-3);
}

TEST(DeformationTransfer, RotatingTheWholeSetupRotatesTheResult) {
  const Grid g = grid(10);
  const std::vector<double> target = mapped(g.points, other_character), pose = mapped(g.points, bent);
  const DeformationTransfer dt(mesh(g.points, g.quads), target);
  const std::vector<double> out = transferred(dt, pose);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  auto turned = [&](const std::vector<double>& p) {
    std::vector<double> o(p.size());
    for (std::size_t i = 0; i < p.size() / 3; ++i) {
      const Vec3 q = r * Vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]) + Vec3(0.5, -1, 2);
      for (int a = 0; a < 3; ++a) o[3 * i + a] = q[a];
    }
    return o;
  };
  const DeformationTransfer moved(mesh(turned(g.points), g.quads), turned(target));
  EXPECT_LT(largest_difference(transferred(moved, turned(pose)), turned(out)), 1e-11);
}

TEST(DeformationTransfer, SeveralPosesAtOnceEqualOneAtATime) {
  const Grid g = grid(10);
  const DeformationTransfer dt(mesh(g.points, g.quads), mapped(g.points, other_character));
  std::vector<double> poses = mapped(g.points, bent);
  const std::vector<double> second = mapped(g.points, other_character);
  poses.insert(poses.end(), second.begin(), second.end());
  std::vector<double> both(poses.size());
  dt.transfer(poses.data(), 2, both.data());
  const std::vector<double> one = transferred(dt, mapped(g.points, bent)), two = transferred(dt, second);
  EXPECT_LT(largest_difference(std::vector<double>(both.begin(), both.begin() + long(one.size())), one), 1e-13);
  EXPECT_LT(largest_difference(std::vector<double>(both.begin() + long(one.size()), both.end()), two), 1e-13);
}

TEST(DeformationTransfer, RefusesBadInputByName) {
  const Grid g = grid(6);
  auto refused = [](auto&& make, const char* name) {
    try {
      make();
      ADD_FAILURE() << "no error for " << name;
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind(name, 0), 0u) << e.what();
    }
  };
  refused([&] { DeformationTransfer(mesh(g.points, g.quads), std::vector<double>(9, 0.0)); }, "target_points");
  std::vector<double> flat = g.points;
  for (int a = 0; a < 3; ++a) flat[3 * 1 + a] = flat[a];  // vertex 1 onto vertex 0: zero-area triangles
  refused([&] { DeformationTransfer(mesh(g.points, g.quads), flat); }, "target_faces");
  refused([&] { DeformationTransfer(mesh(flat, g.quads), g.points); }, "source_faces");
  const DeformationTransfer dt(mesh(g.points, g.quads), g.points);
  std::vector<double> out(g.points.size());
  refused([&] { dt.transfer(flat.data(), 1, out.data()); }, "source_pose");
  std::vector<double> nan = g.points;
  nan[7] = std::nan("");
  refused([&] { dt.transfer(nan.data(), 1, out.data()); }, "source_pose");
}

// A corner moved towards its opposite edge: refused by name once the triangle's area is under 1e-8
// of its longest edge squared (docs/math/transfer.md, "Thin triangles"); accepted above, with the
// rest pose landing on the target rest bit for bit.
TEST(DeformationTransfer, RefusesSliversByNameAndOtherwiseTransfersTheRestExactly) {
  const Grid g = grid(6);
  const std::vector<double> target = mapped(g.points, other_character);
  for (const double lift : {1e-2, 1e-5, 1e-7, 1e-10, 1e-12, 1e-17}) {
    std::vector<double> thin = g.points;
    // Vertex 7 onto the middle of the edge (0, 1) of triangle (0, 1, 7) (quad (0, 1, 7, 6) fanned),
    // lifted off it by `lift`: the shape is about 2.3 lift (edge 0.2 long).
    for (int a = 0; a < 3; ++a) thin[3 * 7 + a] = 0.5 * (thin[a] + thin[3 * 1 + a]);
    thin[3 * 7 + 2] += lift;
    const bool sliver = lift < 1e-8;
    for (const bool on_source : {true, false}) {
      const std::vector<double>& source = on_source ? thin : g.points;
      const std::vector<double>& posed_target = on_source ? target : thin;
      try {
        const DeformationTransfer dt(mesh(source, g.quads), posed_target);
        EXPECT_FALSE(sliver) << lift;
        EXPECT_EQ(transferred(dt, source), posed_target) << lift;
      } catch (const std::invalid_argument& e) {
        EXPECT_TRUE(sliver) << lift << ": " << e.what();
        const std::string expected = std::string(on_source ? "source_faces" : "target_faces") + ": triangle ";
        EXPECT_EQ(std::string(e.what()).rfind(expected, 0), 0u) << e.what();
      }
    }
  }
}
