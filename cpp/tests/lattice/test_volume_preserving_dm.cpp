// docs/math/lattice.md, "Volume-preserving direct manipulation": the cubic volume and its
// gradient against mesh_volume of the deformed mesh and central differences; the closedness
// check; the solve's volume measured the same way.
#include "lattice/lattice_fixtures.hpp"
#include "lattice/mesh_volume_constraint.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace deformkit::test {
namespace {

// An octahedron with its edge midpoints (a subdivided one, 18 vertices, 32 triangles) around c.
PolygonMesh octahedron(const Vec3& c, double r) {
  std::vector<double> p;
  const int axis_points[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (const auto& q : axis_points)
    for (int a = 0; a < 3; ++a) p.push_back(c[a] + r * q[a] * (1.0 + 0.1 * a));
  const int faces[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  std::vector<std::int64_t> corners, offsets{0};
  std::vector<std::array<int, 3>> mids;
  auto mid = [&](int a, int b) {
    for (const auto& m : mids)
      if ((m[0] == a && m[1] == b) || (m[0] == b && m[1] == a)) return m[2];
    const int id = int(p.size() / 3);
    for (int k = 0; k < 3; ++k) p.push_back(0.5 * (p[3 * a + k] + p[3 * b + k]) + 0.02 * r * (k + 1));
    mids.push_back({a, b, id});
    return id;
  };
  for (const auto& f : faces) {
    const int ab = mid(f[0], f[1]), bc = mid(f[1], f[2]), ca = mid(f[2], f[0]);
    for (const std::array<int, 3> t : {std::array<int, 3>{f[0], ab, ca}, {f[1], bc, ab}, {f[2], ca, bc}, {ab, bc, ca}}) {
      corners.insert(corners.end(), t.begin(), t.end());
      offsets.push_back(std::int64_t(corners.size()));
    }
  }
  return PolygonMesh(p.data(), p.size() / 3, corners, offsets);
}

double deformed_volume(const ControlLattice& lat, const PolygonMesh& mesh) {
  std::vector<double> out(mesh.points().size());
  lat.deform(mesh.points().data(), out.data(), mesh.vertex_count());
  PolygonMesh moved(out.data(), mesh.vertex_count(), std::vector<std::int64_t>(mesh.corners().begin(), mesh.corners().end()),
                    [&] {
                      std::vector<std::int64_t> o{0};
                      for (std::size_t f = 0; f < mesh.face_count(); ++f) o.push_back(o.back() + mesh.face_size(f));
                      return o;
                    }());
  return mesh_volume(moved);
}

void add_to_grid(ControlLattice& lat, const Eigen::MatrixXd& dp) {
  auto grid = lat.control_points();
  for (std::size_t g = 0; g < lat.control_count(); ++g)
    for (int a = 0; a < 3; ++a) grid[3 * g + a] += dp(lat.handle_of()[g], a);
  lat.set_control_points(grid);
}

TEST(VolumePreservingDM, VolumeAndGradientMatchTheDeformedMesh) {
  const Vec3 centre = skewed_box().origin + 0.5 * skewed_box().edges.rowwise().sum();
  const PolygonMesh mesh = octahedron(centre, 0.3);
  for (int kind = 0; kind < 2; ++kind) {
    std::shared_ptr<ControlLattice> lat;
    if (kind == 0) lat = std::make_shared<BSplineLattice>(skewed_box(), std::array<int, 3>{5, 6, 4});
    else lat = std::make_shared<BezierFFD>(skewed_box(), std::array<int, 3>{1, 2, 1});
    perturb(*lat, 7, 0.05);
    const LatticeMeshVolume volume(*lat, mesh);
    std::mt19937 rng(11);
    std::normal_distribution<double> n(0.0, 0.04);
    Eigen::MatrixXd dp(lat->handle_count(), 3);
    for (Eigen::Index i = 0; i < dp.size(); ++i) dp.data()[i] = n(rng);
    Eigen::MatrixXd gradient;
    const double v = volume.value(dp, &gradient);
    const auto grid = lat->control_points();
    add_to_grid(*lat, dp);  // the volume holds its own copy of the lattice's state
    EXPECT_NEAR(v, deformed_volume(*lat, mesh), 1e-13) << kind;
    lat->set_control_points(grid);
    const double h = 1e-5;
    for (Eigen::Index k = 0; k < dp.rows(); ++k)
      for (int a = 0; a < 3; ++a) {
        Eigen::MatrixXd plus = dp, minus = dp;
        plus(k, a) += h;
        minus(k, a) -= h;
        // V is cubic: central differences err by h^2/6 of its third derivative.
        EXPECT_NEAR(gradient(k, a), (volume.value(plus) - volume.value(minus)) / (2 * h), 1e-9) << kind << " " << k;
      }
    // The Hessian along a random direction against central differences of the gradient (exact:
    // the gradient is quadratic).
    Eigen::MatrixXd d(dp.rows(), 3), g_plus, g_minus;
    for (Eigen::Index i = 0; i < d.size(); ++i) d.data()[i] = n(rng);
    volume.value(dp + h * d, &g_plus);
    volume.value(dp - h * d, &g_minus);
    const Eigen::MatrixXd hd = volume.hessian_times(dp, d);
    EXPECT_LT((hd - (g_plus - g_minus) / (2 * h)).cwiseAbs().maxCoeff(), 1e-8 * hd.cwiseAbs().maxCoeff()) << kind;
  }
}

TEST(VolumePreservingDM, OpenOrMisorientedMeshesAreRefused) {
  const PolygonMesh mesh = octahedron(Vec3(0.5, 0.5, 0.5), 0.3);
  EXPECT_NO_THROW(require_closed_oriented(mesh));
  std::vector<std::int64_t> corners(mesh.corners().begin(), mesh.corners().end()), offsets{0};
  for (std::size_t f = 0; f < mesh.face_count(); ++f) offsets.push_back(3 * std::int64_t(f + 1));
  auto expect_refusal = [&](const std::vector<std::int64_t>& c, const std::vector<std::int64_t>& o, const char* what) {
    try {
      require_closed_oriented(PolygonMesh(mesh.points().data(), mesh.vertex_count(), c, o));
      ADD_FAILURE() << what;
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind("preserve_volume: mesh_faces: edge", 0), 0u) << e.what();
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  std::vector<std::int64_t> open(corners.begin() + 3, corners.end()), open_offsets(offsets.begin(), offsets.end() - 1);
  expect_refusal(open, open_offsets, "not closed");
  auto flipped = corners;
  std::swap(flipped[1], flipped[2]);
  expect_refusal(flipped, offsets, "same direction");
}

TEST(VolumePreservingDM, TheSolveKeepsTheDeformedMeshVolume) {
  const Vec3 centre = skewed_box().origin + 0.5 * skewed_box().edges.rowwise().sum();
  const PolygonMesh mesh = octahedron(centre, 0.3);
  auto lat = std::make_shared<FFD>(skewed_box(), std::array<int, 3>{3, 3, 2});
  perturb(*lat, 5, 0.03);
  const double before = deformed_volume(*lat, mesh);
  const double* top = &mesh.points()[3 * 4];  // the +z corner
  std::vector<double> target(3);
  lat->deform(top, target.data(), 1);
  target[2] += 0.2;
  const DirectManipulationResult r = direct_manipulation(*lat, top, target.data(), 1, mesh);
  auto moved = *lat;
  moved.set_control_points(r.control_points);
  EXPECT_NEAR(deformed_volume(moved, mesh) / before, 1.0, 1e-10);
  EXPECT_LE(r.volume_residual, 1e-12);
  EXPECT_LT(r.residual[0], 1e-12);
  const DirectManipulationResult free = direct_manipulation(*lat, top, target.data(), 1);
  auto unconstrained = *lat;
  unconstrained.set_control_points(free.control_points);
  EXPECT_GT(std::abs(deformed_volume(unconstrained, mesh) / before - 1.0), 1e-2);
}

}  // namespace
}  // namespace deformkit::test
