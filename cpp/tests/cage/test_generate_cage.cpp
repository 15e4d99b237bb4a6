// The cage generator's parts: the progressive-hull program (cpp/src/cage/generate_cage_hull.hpp)
// against brute force over every vertex of the feasible polytope, and generate_cage's result
// against the cage family's own checks (CageMesh: closed, manifold, oriented, no self-intersection).
#include "cage/generate_cage_hull.hpp"
#include "deformkit/cage/cage_mesh.hpp"
#include "deformkit/cage/generate_cage.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

using namespace deformkit;
using cage_generation::HalfSpace;

namespace {

// The optimum of a bounded three-variable program is a vertex: three tight constraints, feasible.
std::optional<double> brute_force_minimum(const Vec3& c, std::vector<HalfSpace> h, const Vec3& lo, const Vec3& hi) {
  for (int k = 0; k < 3; ++k) h.push_back({Vec3::Unit(k), lo[k]}), h.push_back({-Vec3::Unit(k), -hi[k]});
  std::optional<double> best;
  for (std::size_t i = 0; i < h.size(); ++i)
    for (std::size_t j = i + 1; j < h.size(); ++j)
      for (std::size_t k = j + 1; k < h.size(); ++k) {
        Mat3 a;
        a << h[i].normal.transpose(), h[j].normal.transpose(), h[k].normal.transpose();
        if (std::abs(a.determinant()) < 1e-9) continue;
        const Vec3 x = a.inverse() * Vec3(h[i].offset, h[j].offset, h[k].offset);
        bool feasible = true;
        for (const auto& g : h) feasible = feasible && g.normal.dot(x) >= g.offset - 1e-9;
        if (feasible && (!best || c.dot(x) < *best)) best = c.dot(x);
      }
  return best;
}

}  // namespace

TEST(CageGenerationHull, LowestPointMatchesEveryVertexOfTheFeasibleSet) {
  std::mt19937 rng(7);
  std::normal_distribution<double> g(0.0, 1.0);
  int infeasible = 0;
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<HalfSpace> h;
    const int count = 3 + trial % 12;
    for (int i = 0; i < count; ++i) {
      const Vec3 n = Vec3(g(rng), g(rng), g(rng)).normalized();
      h.push_back({n, 0.5 * g(rng)});
    }
    const Vec3 c(g(rng), g(rng), g(rng)), lo(-2, -2, -2), hi(2, 2, 2);
    const auto x = cage_generation::lowest_point(c, h, lo, hi);
    const auto best = brute_force_minimum(c, h, lo, hi);
    ASSERT_EQ(bool(x), bool(best)) << "trial " << trial;
    if (!x) {
      ++infeasible;
      continue;
    }
    for (const auto& s : h) EXPECT_GE(s.normal.dot(*x), s.offset - 1e-9);
    EXPECT_TRUE(((*x).array() >= lo.array() - 1e-9).all() && ((*x).array() <= hi.array() + 1e-9).all());
    EXPECT_NEAR(c.dot(*x), *best, 1e-7) << "trial " << trial;
  }
  EXPECT_GT(infeasible, 0);  // both outcomes were exercised
  EXPECT_LT(infeasible, 300);
}

TEST(CageGeneration, AnOctahedronsCageIsAValidCageAroundIt) {
  const std::vector<double> p = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
  const std::vector<std::array<int, 3>> t = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                             {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (int budget : {4, 8, 30}) {
    CageGenerationOptions o;
    o.max_faces = budget;
    const GeneratedCage g = generate_cage(p, t, o);
    EXPECT_LE(int(g.face_count()), budget);
    std::vector<std::int64_t> corners(g.corners.begin(), g.corners.end());
    const CageMesh cage(PolygonMesh(g.points.data(), g.points.size() / 3, corners, g.offsets));
    EXPECT_FALSE(cage.flipped());
    EXPECT_GT(cage.volume(), 4.0 / 3.0);  // more than the octahedron's own volume
  }
}

TEST(CageGeneration, RefusesWhatCannotHaveACage) {
  const std::vector<std::array<int, 3>> none;
  EXPECT_THROW(generate_cage({}, none), std::invalid_argument);
  EXPECT_THROW(generate_cage({0, 0, NAN}, none), std::invalid_argument);
  CageGenerationOptions o;
  o.max_faces = 3;
  EXPECT_THROW(generate_cage({0, 0, 0}, none, o), std::invalid_argument);
  EXPECT_THROW(generate_cage({0, 0, 0}, {{0, 1, 2}}), std::invalid_argument);
}
