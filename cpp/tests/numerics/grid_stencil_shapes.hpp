#pragma once
// Mesh Deform's grid system built without a cage: a union of balls stands in for the cage. Unknowns
// are the cells whose centre is inside; an edge to a neighbour outside is cut where the axis segment
// leaves the union (exact distance len, weight 1/len, the boundary value there goes to the
// right-hand side); other edges weigh 1/h. For the grid solver's tests and benchmark.
#include "deformkit/numerics/grid_stencil.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

namespace deformkit::test {

struct Ball {
  Eigen::Vector3d centre;
  double radius;
};

struct CutEdge {
  int unknown;
  Eigen::Vector3d hit;
  double weight;
};

struct ShapeSystem {
  numerics::GridStencil stencil;
  std::vector<Eigen::Vector3d> centre;  // per unknown
  std::vector<CutEdge> cuts;
  double h = 0.0;

  // The right-hand side of boundary values g: sum over each unknown's cut edges of g(hit) / len.
  Eigen::VectorXd rhs(const std::function<double(const Eigen::Vector3d&)>& g) const {
    Eigen::VectorXd b = Eigen::VectorXd::Zero(Eigen::Index(centre.size()));
    for (const CutEdge& e : cuts) b[e.unknown] += e.weight * g(e.hit);
    return b;
  }
};

inline bool inside(const std::vector<Ball>& balls, const Eigen::Vector3d& p) {
  return std::any_of(balls.begin(), balls.end(), [&](const Ball& b) { return (p - b.centre).squaredNorm() < b.radius * b.radius; });
}

// Where p + t e (p inside, e a unit axis) first leaves the union: the end of the chain of
// overlapping chord intervals that starts at t = 0.
inline double exit_distance(const std::vector<Ball>& balls, const Eigen::Vector3d& p, const Eigen::Vector3d& e) {
  double t = 0.0;
  for (bool grew = true; grew;) {
    grew = false;
    for (const Ball& b : balls) {
      const Eigen::Vector3d d = p - b.centre;
      const double half = e.dot(d), disc = half * half - (d.squaredNorm() - b.radius * b.radius);
      if (disc <= 0.0) continue;
      const double t0 = -half - std::sqrt(disc), t1 = -half + std::sqrt(disc);
      if (t0 <= t && t < t1) t = t1, grew = true;
    }
  }
  return t;
}

// An n^3 grid over the unit cube.
inline ShapeSystem shape_system(const std::vector<Ball>& balls, int n) {
  ShapeSystem s;
  s.h = 1.0 / n;
  auto centre = [&](int i, int j, int k) { return Eigen::Vector3d((i + 0.5) * s.h, (j + 0.5) * s.h, (k + 0.5) * s.h); };
  s.stencil.cells = {n, n, n};
  s.stencil.unknown.assign(std::size_t(n) * n * n, -1);
  for (int k = 0, c = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i, ++c)
        if (inside(balls, centre(i, j, k))) s.stencil.unknown[std::size_t(c)] = int(s.centre.size()), s.centre.push_back(centre(i, j, k));
  s.stencil.diagonal.assign(s.centre.size(), 0.0);
  s.stencil.coupling.assign(s.centre.size(), {0, 0, 0, 0, 0, 0});
  const int step[6][3] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}};
  for (int k = 0, c = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i, ++c) {
        const int u = s.stencil.unknown[std::size_t(c)];
        if (u < 0) continue;
        for (int d = 0; d < 6; ++d) {
          const int a = i + step[d][0], b = j + step[d][1], e = k + step[d][2];
          const bool in_grid = a >= 0 && a < n && b >= 0 && b < n && e >= 0 && e < n;
          const int v = in_grid ? s.stencil.unknown[std::size_t(a + n * (b + n * e))] : -1;
          if (v >= 0) {
            s.stencil.coupling[std::size_t(u)][std::size_t(d)] = 1.0 / s.h;
            s.stencil.diagonal[std::size_t(u)] += 1.0 / s.h;
            continue;
          }
          const Eigen::Vector3d axis(step[d][0], step[d][1], step[d][2]);
          const double len = std::min(s.h, exit_distance(balls, s.centre[std::size_t(u)], axis));
          s.cuts.push_back({u, s.centre[std::size_t(u)] + len * axis, 1.0 / len});
          s.stencil.diagonal[std::size_t(u)] += 1.0 / len;
        }
      }
  return s;
}

inline std::vector<Ball> one_ball() { return {{Eigen::Vector3d(0.5, 0.5, 0.5), 0.41}}; }

// A blobby figure: torso, head, arms and legs as chains of overlapping balls, filling about a fifth
// of the cube as a character's cage fills Mesh Deform's cubic grid.
inline std::vector<Ball> figure() {
  std::vector<Ball> balls = {{{0.5, 0.5, 0.52}, 0.16}, {{0.5, 0.5, 0.36}, 0.15}, {{0.5, 0.5, 0.78}, 0.1}};
  for (int side : {-1, 1}) {
    for (int t = 0; t <= 5; ++t) balls.push_back({{0.5 + side * (0.16 + 0.055 * t), 0.5, 0.64 - 0.03 * t}, 0.065 - 0.004 * t});
    for (int t = 0; t <= 5; ++t) balls.push_back({{0.5 + side * (0.08 + 0.015 * t), 0.5 + 0.01 * t, 0.27 - 0.038 * t}, 0.085 - 0.005 * t});
  }
  return balls;
}

}  // namespace deformkit::test
