// PolygonMesh: the checks every family relies on, the fan triangulation, components and the volume
// of meshes whose answers are known in closed form.
#include "deformkit/core/mesh_volume.hpp"
#include "deformkit/core/polygon_mesh.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

using namespace deformkit;

namespace {

// The unit cube [0, 1]^3 as six outward-wound quads.
const std::vector<double> kCube = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1};
const std::vector<std::int64_t> kCubeQuads = {0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4, 2, 3, 7, 6, 1, 2, 6, 5, 0, 4, 7, 3};
const std::vector<std::int64_t> kQuadOffsets = {0, 4, 8, 12, 16, 20, 24};

std::string message_of(const std::vector<double>& points, const std::vector<std::int64_t>& corners,
                       const std::vector<std::int64_t>& offsets) {
  try {
    PolygonMesh mesh(points.data(), points.size() / 3, corners, offsets);
    require_distinct_corners(mesh);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(PolygonMesh, NamesTheBadArgument) {
  const std::vector<double> p = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};
  EXPECT_EQ(message_of(p, {}, {0}), "faces: no faces");
  EXPECT_EQ(message_of(p, {0, 1, 2, 0, 1}, {0, 3, 5}), "faces: face 1 has fewer than 3 corners");
  EXPECT_EQ(message_of(p, {0, 1, 4}, {0, 3}), "faces: face 0 has corner index 4, outside 0..3");
  EXPECT_EQ(message_of(p, {0, -1, 2}, {0, 3}), "faces: face 0 has corner index -1, outside 0..3");
  EXPECT_EQ(message_of(p, {0, 1, 2, 3, 1, 2, 1}, {0, 3, 7}), "faces: face 1 repeats vertex 1");
  std::vector<double> bad = p;
  bad[4] = std::nan("");
  EXPECT_EQ(message_of(bad, {0, 1, 2}, {0, 3}).rfind("points: row 1", 0), 0u);
  EXPECT_EQ(message_of(p, {0, 1, 2, 1, 3, 2}, {0, 3, 6}), "");
}

TEST(PolygonMesh, MeshVolumeRefusesARepeatedVertexAsEveryEntryPoint) {
  const std::vector<double> p = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  const int faces[6] = {0, 1, 2, 0, 3, 3};  // face 1 visits vertex 3 twice
  const PolygonMeshView view = PolygonMeshView::borrowed(p.data(), 4, faces, 2, 3);
  try {
    mesh_volume(view);
    FAIL() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "faces: face 1 repeats vertex 3");
  }
}

TEST(PolygonMesh, TriangulateFansFromTheFirstCorner) {
  const PolygonMesh cube(kCube.data(), 8, kCubeQuads, kQuadOffsets);
  EXPECT_FALSE(cube.all_triangles());
  const PolygonMesh t = cube.triangulate();
  ASSERT_TRUE(t.all_triangles());
  ASSERT_EQ(t.face_count(), 12u);
  EXPECT_EQ(t.points(), cube.points());
  for (std::size_t f = 0; f < cube.face_count(); ++f) {
    const int* q = cube.face(f);
    const int* a = t.face(2 * f);
    const int* b = t.face(2 * f + 1);
    EXPECT_EQ((std::vector<int>{a[0], a[1], a[2], b[0], b[1], b[2]}), (std::vector<int>{q[0], q[1], q[2], q[0], q[2], q[3]}));
  }
  // The same enclosed volume either way: the unit cube's.
  EXPECT_NEAR(mesh_volume(cube), 1.0, 1e-15);
  EXPECT_NEAR(mesh_volume(t), 1.0, 1e-15);
}

TEST(PolygonMesh, ConnectedComponentsThroughFaces) {
  std::vector<double> points = kCube;
  for (double v : kCube) points.push_back(v + 5.0);
  points.insert(points.end(), {9, 9, 9});  // isolated
  std::vector<std::int64_t> corners = kCubeQuads, offsets = kQuadOffsets;
  for (std::int64_t c : kCubeQuads) corners.push_back(c + 8);
  for (std::size_t f = 1; f < kQuadOffsets.size(); ++f) offsets.push_back(kQuadOffsets[f] + 24);
  const PolygonMesh mesh(points.data(), 17, corners, offsets);
  int count = 0;
  const std::vector<int> c = connected_components(mesh, &count);
  EXPECT_EQ(count, 3);
  for (int v = 0; v < 17; ++v) EXPECT_EQ(c[v], v < 8 ? 0 : v < 16 ? 1 : 2) << v;
  EXPECT_NEAR(mesh_volume(mesh), 2.0, 1e-13);
}

// An (m, k) face array read in place is the same mesh as its corner list with offsets, with the
// same checks and messages.
TEST(PolygonMesh, UniformFacesAreTheSameMeshAsOffsets) {
  const std::vector<std::int32_t> quads32(kCubeQuads.begin(), kCubeQuads.end());
  const PolygonMesh listed(kCube.data(), 8, kCubeQuads, kQuadOffsets);
  const PolygonMesh uniform32(kCube.data(), 8, quads32.data(), 6, 4);
  const PolygonMesh uniform64(kCube.data(), 8, kCubeQuads.data(), 6, 4);
  for (const PolygonMesh* m : {&uniform32, &uniform64}) {
    ASSERT_EQ(m->face_count(), listed.face_count());
    EXPECT_EQ(m->corners(), listed.corners());
    EXPECT_EQ(m->points(), listed.points());
    for (std::size_t f = 0; f < listed.face_count(); ++f) EXPECT_EQ(m->face_size(f), listed.face_size(f));
    EXPECT_EQ(mesh_volume(*m), mesh_volume(listed));
    EXPECT_EQ(m->triangulate().corners(), listed.triangulate().corners());
  }
  const std::vector<std::int64_t> bad = {0, 1, 2, 0, 1, 8};
  try {
    PolygonMesh(kCube.data(), 8, bad.data(), 2, 3);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "faces: face 1 has corner index 8, outside 0..7");
  }
  EXPECT_THROW(PolygonMesh(kCube.data(), 8, bad.data(), 0, 3), std::invalid_argument);
}

// A borrowed view of the caller's arrays is checked as a copied mesh is, and measures the same.
TEST(PolygonMesh, BorrowedViewChecksAndMeasuresAsTheCopy) {
  const std::vector<int> quads(kCubeQuads.begin(), kCubeQuads.end());
  const PolygonMesh copied(kCube.data(), 8, quads.data(), 6, 4);
  const PolygonMeshView view = PolygonMeshView::borrowed(kCube.data(), 8, quads.data(), 6, 4);
  EXPECT_EQ(view.points, kCube.data());
  EXPECT_EQ(view.corners, quads.data());
  EXPECT_EQ(mesh_volume(view), mesh_volume(copied));
  const std::vector<int> bad = {0, 1, 2, 0, 1, 8};
  for (auto make : {+[](const int* f) { (void)PolygonMeshView::borrowed(kCube.data(), 8, f, 2, 3); },
                    +[](const int* f) { (void)PolygonMesh(kCube.data(), 8, f, 2, 3); }}) {
    try {
      make(bad.data());
      FAIL();
    } catch (const std::invalid_argument& e) {
      EXPECT_STREQ(e.what(), "faces: face 1 has corner index 8, outside 0..7");
    }
  }
}
