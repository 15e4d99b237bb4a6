#pragma once
// A polygon control mesh for subdivision: faces, sharpness tags and per-corner UVs, checked.
#include "deformkit/core/polygon_mesh.hpp"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace deformkit {

enum class SubdivisionScheme { CatmullClark, Loop };
// EdgeAndCorner is Blender's "Keep Corners"; EdgeOnly is its "Smooth" boundary.
enum class BoundaryRule { EdgeAndCorner, EdgeOnly };
// Blender's UV Smooth choices, in OpenSubdiv's face-varying linear interpolation terms.
enum class UvSmooth { None, PreserveCorners, PreserveCornersAndJunctions, PreserveCornersJunctionsAndConcave,
                      PreserveBoundaries, SmoothAll };

// OpenSubdiv's infinitely sharp crease (Sdc::Crease::SHARPNESS_INFINITE).
constexpr double kInfiniteSharpness = 10.0;

struct ControlMesh {
  PolygonMesh polygons;            // the faces, and the points of the cage it was made with
  std::vector<int> crease_edges;   // vertex pairs
  std::vector<double> crease_sharpness;
  std::vector<int> corner_vertices;
  std::vector<double> corner_sharpness;
  std::vector<double> uvs;          // welded face-varying values (u, v)
  std::vector<int> uv_indices;      // per corner, into uvs; empty without UVs
  SubdivisionScheme scheme = SubdivisionScheme::CatmullClark;
  BoundaryRule boundary = BoundaryRule::EdgeAndCorner;
  UvSmooth uv_smooth = UvSmooth::PreserveBoundaries;
  // Blender's topology rule: a vertex with exactly two edges also takes the smaller of their
  // crease sharpnesses (vertex sharpness + min, capped at 10), so creased borders keep corners.
  bool sharpen_two_edge_vertices = true;

  std::size_t vertex_count() const { return polygons.vertex_count(); }
  std::size_t face_count() const { return polygons.face_count(); }
  int face_size(std::size_t f) const { return polygons.face_size(f); }
  const std::vector<int>& corners() const { return polygons.corners(); }
};

// A control mesh on a (checked) polygon mesh. Throws std::invalid_argument naming the argument
// (`faces`, `creases`, `corners`, `uvs`) for, on top of PolygonMesh's checks: a repeated vertex
// in a face, a vertex in no face, an edge of more than two faces or used twice in one direction
// (non-manifold or inconsistently wound), non-triangles under Loop, negative or NaN sharpness, a
// crease on a non-edge, non-finite UVs. Corners with equal vertex and UV share one UV value.
ControlMesh make_control_mesh(PolygonMesh polygons, SubdivisionScheme scheme, BoundaryRule boundary);
void set_creases(ControlMesh& mesh, const std::vector<std::int64_t>& edges, const std::vector<double>& sharpness);
void set_corners(ControlMesh& mesh, const std::vector<std::int64_t>& vertices, const std::vector<double>& sharpness);
void set_uvs(ControlMesh& mesh, const double* corner_uvs, std::size_t corner_count, UvSmooth smooth);

// Every edge as (a, b) with a < b, sorted, and the faces on each side: (face, local edge) pairs,
// edge_faces[e] listing one or two of them. Local edge i runs from corner i to corner i + 1.
struct EdgeTopology {
  std::vector<int> edges;                      // 2 per edge
  std::vector<int> face_offsets;               // per edge into face_of/local_of (size edges + 1)
  std::vector<int> face_of, local_of;
};
EdgeTopology edge_topology(const ControlMesh& mesh);

// The sharpness OpenSubdiv gets for every vertex: `corners` (the last value of a repeated vertex,
// as OpenSubdiv reads them) and, with sharpen_two_edge_vertices, Blender's two-edge rule on top.
std::vector<double> vertex_sharpness(const ControlMesh& mesh);

std::string scheme_name(SubdivisionScheme s);

}  // namespace deformkit
