#include "test_util.hpp"

#include <gtest/gtest.h>

using namespace deformkit;

namespace {

// An n x n grid of quads in the plane z = 0, lightly bumped, fanned into triangles.
PolygonMesh grid(int n, double bump, double shift = 0.0) {
  std::vector<double> pts;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) pts.insert(pts.end(), {double(i) + shift, double(j) + shift, bump * std::sin(i + 2.0 * j) + shift});
  std::vector<std::int64_t> corners, offsets{0};
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j + 1 < n; ++j) {
      corners.insert(corners.end(), {i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1});
      offsets.push_back(std::int64_t(corners.size()));
    }
  return PolygonMesh(pts.data(), pts.size() / 3, corners, offsets).triangulate();
}

// Two meshes side by side, b's vertices numbered after a's.
PolygonMesh disjoint_union(const PolygonMesh& a, const PolygonMesh& b) {
  std::vector<double> points = a.points();
  points.insert(points.end(), b.points().begin(), b.points().end());
  std::vector<std::int64_t> corners(a.corners().begin(), a.corners().end()), offsets{0};
  for (int c : b.corners()) corners.push_back(c + std::int64_t(a.vertex_count()));
  for (const PolygonMesh* m : {&a, &b})
    for (std::size_t f = 0; f < m->face_count(); ++f) offsets.push_back(offsets.back() + m->face_size(f));
  return PolygonMesh(points.data(), points.size() / 3, corners, offsets);
}

}  // namespace

TEST(Laplacian, SymmetricRowsSumToZeroAndLinearPrecisionInside) {
  const PolygonMesh mesh = grid(6, 0.0);
  for (const SparseMatrix& l : {cotangent_laplacian(mesh), uniform_laplacian(mesh)}) {
    const Eigen::MatrixXd d(l);
    EXPECT_LT((d - d.transpose()).cwiseAbs().maxCoeff(), 1e-14);
    EXPECT_LT(d.rowwise().sum().cwiseAbs().maxCoeff(), 1e-12);
  }
  // The cotangent Laplacian of a linear function vanishes at interior vertices of a flat mesh.
  const Eigen::MatrixXd l(cotangent_laplacian(mesh));
  Eigen::VectorXd f(36);
  for (int v = 0; v < 36; ++v) f[v] = 2.0 * mesh.points()[3 * v] - 0.5 * mesh.points()[3 * v + 1];
  const Eigen::VectorXd lf = l * f;
  for (int i = 1; i < 5; ++i)
    for (int j = 1; j < 5; ++j) EXPECT_NEAR(lf[i * 6 + j], 0.0, 1e-12);
}

TEST(SurfaceDeformer, RestIsReproducedByEveryMethod) {
  const PolygonMesh mesh = grid(8, 0.3);
  for (SurfaceMethod m : {SurfaceMethod::Laplacian, SurfaceMethod::RotationInvariant, SurfaceMethod::Arap}) {
    SurfaceSettings s;
    s.method = m;
    SurfaceDeformer d(mesh, {0, 1, 2}, {61, 62, 63}, std::nullopt, s);
    std::vector<double> targets;
    for (int h : {61, 62, 63}) targets.insert(targets.end(), &mesh.points()[3 * h], &mesh.points()[3 * h + 3]);
    const auto out = d.deform(targets.data());
    for (std::size_t i = 0; i < out.size(); ++i) EXPECT_NEAR(out[i], mesh.points()[i], 1e-9) << int(m);
  }
}

TEST(SurfaceDeformer, ArapFollowsARigidMotionAndItsEnergyDecreases) {
  const PolygonMesh mesh = grid(7, 0.4);
  const Mat3 r = Eigen::AngleAxisd(1.2, Vec3(0.3, 0.5, 0.8).normalized()).toRotationMatrix();
  const Vec3 shift(0.5, -1.0, 2.0);
  std::vector<int> handles;
  std::vector<double> targets;
  for (int v : {0, 1, 7, 47, 48, 41, 24}) {
    handles.push_back(v);
    const Vec3 p = r * Vec3(mesh.points()[3 * v], mesh.points()[3 * v + 1], mesh.points()[3 * v + 2]) + shift;
    targets.insert(targets.end(), {p[0], p[1], p[2]});
  }
  SurfaceSettings s;
  s.iterations = 1000;  // from R = I, ARAP converges linearly: slowly after a large rotation
  SurfaceDeformer d(mesh, {}, handles, std::nullopt, s);
  const auto out = d.deform(targets.data());
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const Vec3 p = r * Vec3(mesh.points()[3 * v], mesh.points()[3 * v + 1], mesh.points()[3 * v + 2]) + shift;
    EXPECT_LT((Vec3(out[3 * v], out[3 * v + 1], out[3 * v + 2]) - p).norm(), 1e-4);
  }
  for (std::size_t k = 1; k < d.energy().size(); ++k) EXPECT_LE(d.energy()[k], d.energy()[k - 1] * (1 + 1e-12));
}

TEST(SurfaceDeformer, UnheldComponentStaysAndIsReported) {
  const PolygonMesh both = disjoint_union(grid(4, 0.1), grid(4, 0.1, 10.0));
  SurfaceDeformer d(both, {0}, {15}, std::nullopt, SurfaceSettings{});
  const double target[3] = {3.0, 3.0, 2.0};
  const auto out = d.deform(target);
  ASSERT_EQ(d.warnings().size(), 1u);
  for (std::size_t i = 48; i < out.size(); ++i) EXPECT_EQ(out[i], both.points()[i]);
}
