// Blender's subdivided-mesh numbering against its layout read off the positions: on a flat grid of
// equal squares with corners kept, Catmull-Clark refinement is bilinear, so every refined vertex
// sits where Blender's layout (docs/subdivision.md, "Blender's order") says its index is.
#include "deformkit/subdivision/blender_order.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <stdexcept>

namespace deformkit {
namespace {

// A 3 x 2 grid of unit squares; faces start at different corners, edges point both ways.
struct Grid {
  std::vector<double> points;
  std::vector<int> corners;
  std::vector<int> edges;  // Blender-style: numbered and oriented by the caller
  Grid() {
    for (int y = 0; y <= 2; ++y)
      for (int x = 0; x <= 3; ++x) points.insert(points.end(), {double(x), double(y), 0.0});
    const int quads[6][4] = {{0, 1, 5, 4}, {2, 6, 5, 1}, {7, 6, 2, 3}, {8, 4, 5, 9}, {5, 6, 10, 9}, {11, 10, 6, 7}};
    for (const auto& q : quads) corners.insert(corners.end(), q, q + 4);
    std::set<std::pair<int, int>> seen;
    for (int f = 0; f < 6; ++f)
      for (int c = 0; c < 4; ++c) {
        const int a = quads[f][c], b = quads[f][(c + 1) % 4];
        if (seen.insert({std::min(a, b), std::max(a, b)}).second) {
          // every third edge runs high to low
          const bool flip = seen.size() % 3 == 0;
          edges.insert(edges.end(), {flip ? std::max(a, b) : std::min(a, b), flip ? std::min(a, b) : std::max(a, b)});
        }
      }
  }
  ControlMesh mesh() const {
    std::vector<std::int64_t> c(corners.begin(), corners.end()), offsets;
    for (std::int64_t f = 0; f <= 6; ++f) offsets.push_back(4 * f);
    return make_control_mesh(PolygonMesh(points.data(), points.size() / 3, c, offsets), SubdivisionScheme::CatmullClark,
                             BoundaryRule::EdgeAndCorner);
  }
  std::array<double, 2> at(int v) const { return {points[3 * v], points[3 * v + 1]}; }
};

std::array<double, 2> lerp(std::array<double, 2> a, std::array<double, 2> b, double t) {
  return {a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])};
}

TEST(BlenderOrder, VerticesEdgesAndFacesFollowBlendersLayoutOnAFlatGrid) {
  const Grid grid;
  for (int level = 1; level <= 3; ++level) {
    const Subdivider s(grid.mesh(), level, kDefaultMaxFaces);
    const int n = 1 << level;
    const std::size_t ne = grid.edges.size() / 2;
    const BlenderOrder order = blender_order(s, grid.edges.data(), ne);
    // Where Blender's layout puts each index: vertices, edges' inner points, faces' inner grids.
    std::vector<std::array<double, 2>> expected;
    for (int v = 0; v < 12; ++v) expected.push_back(grid.at(v));
    for (std::size_t e = 0; e < ne; ++e)
      for (int i = 1; i < n; ++i) expected.push_back(lerp(grid.at(grid.edges[2 * e]), grid.at(grid.edges[2 * e + 1]), double(i) / n));
    for (int f = 0; f < 6; ++f) {
      const int* c = grid.corners.data() + 4 * f;
      for (int y = 1; y < n; ++y)
        for (int x = 1; x < n; ++x)
          expected.push_back(lerp(lerp(grid.at(c[0]), grid.at(c[1]), double(x) / n),
                                  lerp(grid.at(c[3]), grid.at(c[2]), double(x) / n), double(y) / n));
    }
    const std::vector<double> points = s.subdivide(grid.points.data());
    ASSERT_EQ(order.vertex.size(), expected.size());
    for (std::size_t i = 0; i < order.vertex.size(); ++i) {
      const auto& want = expected[order.vertex[i]];
      EXPECT_NEAR(points[3 * i], want[0], 1e-12) << "level " << level << " vertex " << i;
      EXPECT_NEAR(points[3 * i + 1], want[1], 1e-12) << "level " << level << " vertex " << i;
    }
    // Edges: the first n of each control edge run from its first vertex to its second, and all
    // of them are exactly the edges of the refined faces.
    ASSERT_EQ(order.edges.size() / 2, ne * n + 6 * 2 * std::size_t(n) * (n - 1));
    for (std::size_t e = 0; e < ne; ++e)
      for (int i = 0; i < n; ++i) {
        const auto a = expected[order.edges[2 * (e * n + i)]], b = expected[order.edges[2 * (e * n + i) + 1]];
        const auto want = lerp(grid.at(grid.edges[2 * e]), grid.at(grid.edges[2 * e + 1]), double(i) / n);
        EXPECT_NEAR(a[0], want[0], 1e-12);
        EXPECT_NEAR(a[1], want[1], 1e-12);
        EXPECT_NEAR(std::hypot(b[0] - a[0], b[1] - a[1]), 1.0 / n, 1e-12);
      }
    std::set<std::pair<int, int>> face_edges, listed;
    const std::vector<int>& faces = s.faces();
    for (std::size_t f = 0; f < faces.size() / 4; ++f)
      for (int c = 0; c < 4; ++c) {
        const int a = order.vertex[faces[4 * f + c]], b = order.vertex[faces[4 * f + (c + 1) % 4]];
        face_edges.insert({std::min(a, b), std::max(a, b)});
      }
    for (std::size_t e = 0; e < order.edges.size(); e += 2)
      listed.insert({std::min(order.edges[e], order.edges[e + 1]), std::max(order.edges[e], order.edges[e + 1])});
    EXPECT_EQ(listed, face_edges);
    EXPECT_EQ(listed.size(), order.edges.size() / 2);
    // Faces: a permutation; Blender's first corner is the one nearest its control face's corner 0
    // along the face's own grid (lowest x, then lowest y, in the control face's parameters).
    std::vector<int> sorted_faces = order.face;
    std::sort(sorted_faces.begin(), sorted_faces.end());
    for (std::size_t f = 0; f < sorted_faces.size(); ++f) ASSERT_EQ(sorted_faces[f], int(f));
    // Blender numbers the faces control face by control face.
    for (std::size_t f = 0; f < order.face.size(); ++f)
      EXPECT_EQ(order.face[f] / (n * n), s.face_origin()[f]) << "level " << level << " face " << f;
  }
}

TEST(BlenderOrder, RefusesEdgesThatAreNotTheFacesEdges) {
  const Grid grid;
  const Subdivider s(grid.mesh(), 2, kDefaultMaxFaces);
  std::vector<int> edges = grid.edges;
  EXPECT_THROW(blender_order(s, edges.data(), edges.size() / 2 - 1), std::invalid_argument);  // one missing
  edges.insert(edges.end(), {0, 11});
  EXPECT_THROW(blender_order(s, edges.data(), edges.size() / 2), std::invalid_argument);  // a loose edge
  edges = grid.edges;
  edges.insert(edges.end(), {edges[0], edges[1]});
  EXPECT_THROW(blender_order(s, edges.data(), edges.size() / 2), std::invalid_argument);  // repeated
  edges = grid.edges;
  edges[0] = 12;
  EXPECT_THROW(blender_order(s, edges.data(), edges.size() / 2), std::invalid_argument);  // out of range
}

}  // namespace
}  // namespace deformkit
