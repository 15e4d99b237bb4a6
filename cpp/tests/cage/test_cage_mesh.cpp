// The cage's checks, the flip of an inward cage and the polygon split rule.
#include "cage/cage_shapes.hpp"
#include "deformkit/core/mesh_volume.hpp"
#include "deformkit/core/types.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

using namespace deformkit;
using namespace deformkit::test;

namespace {

bool starts_with(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

}  // namespace

TEST(CageMesh, CubeAndLPrismAreClosedAndOutward) {
  for (const PolygonSoup& s : {unit_cube(), l_prism()}) {
    const CageMesh cage(polygon_mesh(s));
    EXPECT_FALSE(cage.flipped());
    // The triangles enclose the mesh's own volume (the core's fan of the polygons).
    EXPECT_NEAR(cage.volume(), mesh_volume(polygon_mesh(s)), 1e-15);
    std::size_t corners = 0;
    for (const auto& f : s.faces) corners += f.size() - 2;
    EXPECT_EQ(cage.triangles().size(), corners);  // a polygon of k corners gives k - 2 triangles
  }
  EXPECT_DOUBLE_EQ(CageMesh(polygon_mesh(unit_cube())).volume(), 1.0);
  EXPECT_DOUBLE_EQ(CageMesh(polygon_mesh(l_prism())).volume(), 3.0);
}

TEST(CageMesh, AnInwardCageIsFlipped) {
  PolygonSoup s = l_prism();
  for (auto& f : s.faces) std::reverse(f.begin(), f.end());
  const CageMesh inward(polygon_mesh(s)), outward(polygon_mesh(l_prism()));
  EXPECT_TRUE(inward.flipped());
  EXPECT_DOUBLE_EQ(inward.volume(), 3.0);
  // The same triangles, each oriented as the outward cage's.
  auto sorted = [](std::vector<CageTriangle> t) {
    std::sort(t.begin(), t.end());
    return t;
  };
  EXPECT_EQ(sorted(inward.triangles()), sorted(outward.triangles()));
}

TEST(CageMesh, EveryBadCageNamesItsFirstOffence) {
  PolygonSoup open = unit_cube();
  open.faces.pop_back();
  EXPECT_EQ(error_of(open), "faces: edge (1, 3) of face 0 belongs to no other face: the cage is open (it must be closed)");

  PolygonSoup turned = unit_cube();
  std::reverse(turned.faces[3].begin(), turned.faces[3].end());
  EXPECT_TRUE(starts_with(error_of(turned), "faces: edge (3, 2) runs the same way in faces 0 and 3"));

  PolygonSoup fin = unit_cube();  // a seventh face on the edge (0, 1): three faces meet there
  fin.points.insert(fin.points.end(), {-1.0, 0.0, 0.5});
  fin.faces.push_back({0, 1, 8});
  EXPECT_TRUE(starts_with(error_of(fin), "faces: edge (0, 1) is shared by 3 faces (0, 2, 6): the cage is non-manifold"));

  PolygonSoup repeated = unit_cube();
  repeated.faces[1] = {4, 6, 7, 6};
  EXPECT_TRUE(starts_with(error_of(repeated), "faces: face 1 repeats vertex 6"));

  PolygonSoup flat = unit_cube();
  for (int v : {4, 5, 6, 7}) flat.points[3 * v] = 0.0;  // the cube squashed onto x = 0: face 2 a segment
  EXPECT_EQ(error_of(flat), "faces: face 2 has zero area (degenerate)");

  PolygonSoup sliver = unit_cube();  // face 0's corner 3 moved onto the line of corners 1 and 2
  sliver.points[3 * 3 + 1] = 1.0, sliver.points[3 * 3 + 2] = 0.0;
  sliver.faces[0] = {0, 1, 3, 2};
  EXPECT_NE(error_of(sliver), "");

  PolygonSoup far = unit_cube();
  far.faces[0][0] = 8;
  EXPECT_TRUE(starts_with(error_of(far), "faces: "));

  PolygonSoup nan = unit_cube();
  nan.points[4] = std::nan("");
  EXPECT_TRUE(starts_with(error_of(nan), "points: row 1"));

  // Two cubes that interpenetrate: each closed and outward, together self-intersecting.
  PolygonSoup two = unit_cube();
  const PolygonSoup b = unit_cube();
  const double shift[3] = {0.5, 0.3, 0.4};
  for (std::size_t i = 0; i < b.points.size(); ++i) two.points.push_back(b.points[i] + shift[i % 3]);
  for (auto f : b.faces) {
    for (int& v : f) v += 8;
    two.faces.push_back(f);
  }
  EXPECT_TRUE(starts_with(error_of(two), "faces: faces ")) << error_of(two);
  EXPECT_NE(error_of(two).find("intersect (the cage intersects itself)"), std::string::npos);
}

TEST(SplitPolygon, AQuadSplitsAlongItsShorterDiagonal) {
  // A kite: diagonal 0-2 has length 2, diagonal 1-3 length 1.
  const double p[] = {-1, 0, 0, 0, -0.5, 0, 1, 0, 0, 0, 0.5, 0};
  const int quad[] = {0, 1, 2, 3};
  const auto t = split_polygon(p, quad, 4);
  ASSERT_EQ(t.size(), 2u);
  for (const auto& tri : t) EXPECT_TRUE(std::count(tri.begin(), tri.end(), 1) && std::count(tri.begin(), tri.end(), 3));
  const double q[] = {-1, 0, 0, 0, -2, 0, 1, 0, 0, 0, 2, 0};  // now 0-2 is the shorter
  for (const auto& tri : split_polygon(q, quad, 4))
    EXPECT_TRUE(std::count(tri.begin(), tri.end(), 0) && std::count(tri.begin(), tri.end(), 2));
}

TEST(SplitPolygon, DoesNotDependOnTheFirstCornerListed) {
  const PolygonSoup s = l_prism();
  for (const auto& face : s.faces) {
    const auto reference = split_polygon(s.points.data(), face.data(), int(face.size()));
    ASSERT_EQ(reference.size(), face.size() - 2);
    for (std::size_t r = 1; r < face.size(); ++r) {
      std::vector<int> rotated(face.begin() + std::ptrdiff_t(r), face.end());
      rotated.insert(rotated.end(), face.begin(), face.begin() + std::ptrdiff_t(r));
      EXPECT_EQ(split_polygon(s.points.data(), rotated.data(), int(rotated.size())), reference);
    }
    // Every triangle keeps the polygon's orientation: its normal points as the polygon's area vector.
    const auto pt = [&](int v) { return Vec3(s.points[3 * v], s.points[3 * v + 1], s.points[3 * v + 2]); };
    Vec3 area = Vec3::Zero();
    for (std::size_t i = 0; i < face.size(); ++i) area += pt(face[i]).cross(pt(face[(i + 1) % face.size()]));
    for (const auto& t : reference) EXPECT_GT((pt(t[1]) - pt(t[0])).cross(pt(t[2]) - pt(t[0])).dot(area), 0.0);
  }
}
