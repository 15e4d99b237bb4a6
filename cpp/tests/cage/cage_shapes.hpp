#pragma once
// Cages the cage tests share: a unit cube of quads, and a non-convex L-shaped prism whose caps are
// hexagons (polygons of more than four corners).
#include "deformkit/cage/cage_mesh.hpp"

#include <cstdint>
#include <stdexcept>
#include <string>
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
