#pragma once
// Cages the cage tests share: a unit cube of quads (also with each side split into n x n quads),
// and a non-convex L-shaped prism whose caps are hexagons (polygons of more than four corners).
#include "deformkit/cage/cage_mesh.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace deformkit::test {

struct PolygonSoup {
  std::vector<double> points;
  std::vector<std::vector<int>> faces;
};

inline PolygonMesh polygon_mesh(const PolygonSoup& s) {
  std::vector<std::int64_t> corners, offsets{0};
  for (const auto& f : s.faces) {
    corners.insert(corners.end(), f.begin(), f.end());
    offsets.push_back(std::int64_t(corners.size()));
  }
  return PolygonMesh(s.points.data(), s.points.size() / 3, corners, offsets);
}

// What the cage's checks say about s: the message of the refusal, or "" for a valid cage.
inline std::string error_of(const PolygonSoup& s) {
  try {
    CageMesh cage(polygon_mesh(s));
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// Outward quads of [0, 1]^3; vertex (x, y, z) is 4 x + 2 y + z.
inline PolygonSoup unit_cube() {
  PolygonSoup s;
  for (int x = 0; x < 2; ++x)
    for (int y = 0; y < 2; ++y)
      for (int z = 0; z < 2; ++z) s.points.insert(s.points.end(), {double(x), double(y), double(z)});
  s.faces = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
  return s;
}

// [0, 1]^3 with each side an n x n grid of outward quads: 6 n^2 + 2 vertices.
inline PolygonSoup subdivided_cube(int n) {
  PolygonSoup s;
  std::map<std::array<int, 3>, int> index;
  auto vertex = [&](std::array<int, 3> g) {
    auto [at, added] = index.emplace(g, int(index.size()));
    if (added)
      for (int c : g) s.points.push_back(double(c) / n);
    return at->second;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int side : {0, n}) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;  // e_u x e_v = e_axis: outward on side n
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          std::vector<int> f;
          for (auto [du, dv] : {std::pair{0, 0}, {1, 0}, {1, 1}, {0, 1}}) {
            std::array<int, 3> g{};
            g[std::size_t(axis)] = side;
            g[std::size_t(u)] = i + du;
            g[std::size_t(v)] = j + dv;
            f.push_back(vertex(g));
          }
          if (side == 0) std::reverse(f.begin(), f.end());
          s.faces.push_back(f);
        }
    }
  return s;
}

// The L (0,0) (2,0) (2,1) (1,1) (1,2) (0,2) extruded over z in [0, 1]: bottom ring 0..5, top 6..11.
inline PolygonSoup l_prism() {
  const double ring[6][2] = {{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}};
  PolygonSoup s;
  for (int z = 0; z < 2; ++z)
    for (const auto& r : ring) s.points.insert(s.points.end(), {r[0], r[1], double(z)});
  s.faces.push_back({5, 4, 3, 2, 1, 0});    // bottom, seen from below
  s.faces.push_back({6, 7, 8, 9, 10, 11});  // top
  for (int i = 0; i < 6; ++i) s.faces.push_back({i, (i + 1) % 6, 6 + (i + 1) % 6, 6 + i});
  return s;
}

}  // namespace deformkit::test
