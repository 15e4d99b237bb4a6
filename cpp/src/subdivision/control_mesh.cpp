#include "deformkit/subdivision/control_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <tuple>

namespace deformkit {

namespace {

struct HalfEdge {
  int a, b;  // a < b
  int face, local;
  bool forward;  // the face runs a -> b
  bool operator<(const HalfEdge& o) const { return std::tie(a, b, face, local) < std::tie(o.a, o.b, o.face, o.local); }
};

std::vector<HalfEdge> half_edges(const ControlMesh& mesh) {
  std::vector<HalfEdge> h;
  h.reserve(mesh.corners().size());
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const int k = mesh.face_size(f);
    const int* c = mesh.polygons.face(f);
    for (int i = 0; i < k; ++i) {
      const int p = c[i], q = c[(i + 1) % k];
      h.push_back({std::min(p, q), std::max(p, q), int(f), i, p < q});
    }
  }
  std::sort(h.begin(), h.end());
  return h;
}

std::string pair_text(int a, int b) { return "(" + std::to_string(a) + ", " + std::to_string(b) + ")"; }

void check_sharpness(const std::vector<double>& s, const char* name) {
  for (std::size_t i = 0; i < s.size(); ++i)
    if (!(s[i] >= 0.0))  // also catches NaN
      throw std::invalid_argument(std::string(name) + ": sharpness " + std::to_string(i) +
                                  " is negative or NaN (must be >= 0; 10 is infinitely sharp)");
}

}  // namespace

std::string scheme_name(SubdivisionScheme s) { return s == SubdivisionScheme::Loop ? "loop" : "catmull_clark"; }

ControlMesh make_control_mesh(PolygonMesh polygons, SubdivisionScheme scheme, BoundaryRule boundary) {
  if (polygons.vertex_count() > std::size_t(1) << 30) throw std::invalid_argument("points: more than 2^30 vertices");
  if (scheme == SubdivisionScheme::Loop)
    for (std::size_t f = 0; f < polygons.face_count(); ++f)
      if (polygons.face_size(f) != 3)
        throw std::invalid_argument("faces: the Loop scheme needs triangles; face " + std::to_string(f) + " has " +
                                    std::to_string(polygons.face_size(f)) + " corners");
  require_distinct_corners(polygons);
  std::vector<char> used(polygons.vertex_count(), 0);
  for (int v : polygons.corners()) used[v] = 1;
  const auto isolated = std::find(used.begin(), used.end(), 0);
  if (isolated != used.end())
    throw std::invalid_argument("points: vertex " + std::to_string(isolated - used.begin()) +
                                " is in no face (isolated vertices have no limit surface; remove them)");
  ControlMesh mesh;
  mesh.polygons = std::move(polygons);
  mesh.scheme = scheme;
  mesh.boundary = boundary;
  const std::vector<HalfEdge> h = half_edges(mesh);
  for (std::size_t i = 0; i < h.size();) {
    std::size_t j = i + 1;
    while (j < h.size() && h[j].a == h[i].a && h[j].b == h[i].b) ++j;
    if (j - i > 2)
      throw std::invalid_argument("faces: edge " + pair_text(h[i].a, h[i].b) + " has " + std::to_string(j - i) +
                                  " faces (non-manifold; at most 2 faces may share an edge)");
    if (j - i == 2 && h[i].forward == h[i + 1].forward)
      throw std::invalid_argument("faces: faces " + std::to_string(h[i].face) + " and " + std::to_string(h[i + 1].face) +
                                  " run along edge " + pair_text(h[i].a, h[i].b) +
                                  " in the same direction (inconsistent winding or a non-manifold fold)");
    i = j;
  }
  return mesh;
}

void set_creases(ControlMesh& mesh, const std::vector<std::int64_t>& edges, const std::vector<double>& sharpness) {
  if (edges.size() != 2 * sharpness.size())
    throw std::invalid_argument("creases: expected (edges (k, 2), sharpness (k,)) with equal k, got " +
                                std::to_string(edges.size() / 2) + " edges and " + std::to_string(sharpness.size()) +
                                " sharpness values");
  check_sharpness(sharpness, "creases");
  const std::vector<HalfEdge> h = half_edges(mesh);
  mesh.crease_edges.clear();
  for (std::size_t k = 0; k < sharpness.size(); ++k) {
    const std::int64_t p = edges[2 * k], q = edges[2 * k + 1];
    const HalfEdge key{int(std::min(p, q)), int(std::max(p, q)), -1, -1, true};
    const auto it = std::lower_bound(h.begin(), h.end(), key);
    if (p < 0 || q < 0 || std::size_t(std::max(p, q)) >= mesh.vertex_count() || it == h.end() || it->a != key.a ||
        it->b != key.b)
      throw std::invalid_argument("creases: pair " + std::to_string(k) + " " + pair_text(int(p), int(q)) +
                                  " is not an edge of the mesh");
    mesh.crease_edges.insert(mesh.crease_edges.end(), {int(p), int(q)});
  }
  mesh.crease_sharpness = sharpness;
}

void set_corners(ControlMesh& mesh, const std::vector<std::int64_t>& vertices, const std::vector<double>& sharpness) {
  if (vertices.size() != sharpness.size())
    throw std::invalid_argument("corners: expected (vertices (c,), sharpness (c,)) of equal length, got " +
                                std::to_string(vertices.size()) + " and " + std::to_string(sharpness.size()));
  check_sharpness(sharpness, "corners");
  mesh.corner_vertices.clear();
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    if (vertices[k] < 0 || std::size_t(vertices[k]) >= mesh.vertex_count())
      throw std::invalid_argument("corners: vertex index " + std::to_string(vertices[k]) + " is outside 0.." +
                                  std::to_string(std::int64_t(mesh.vertex_count()) - 1));
    mesh.corner_vertices.push_back(int(vertices[k]));
  }
  mesh.corner_sharpness = sharpness;
}

void set_uvs(ControlMesh& mesh, const double* corner_uvs, std::size_t corner_count, UvSmooth smooth) {
  if (corner_count != mesh.corners().size())
    throw std::invalid_argument("uvs: expected one (u, v) per face corner (" + std::to_string(mesh.corners().size()) +
                                " rows), got " + std::to_string(corner_count));
  // Corners of one vertex with equal UVs are one face-varying value; a seam keeps two.
  std::map<std::tuple<int, double, double>, int> welded;
  mesh.uvs.clear();
  mesh.uv_indices.resize(corner_count);
  for (std::size_t c = 0; c < corner_count; ++c) {
    const double u = corner_uvs[2 * c], v = corner_uvs[2 * c + 1];
    if (!std::isfinite(u) || !std::isfinite(v))
      throw std::invalid_argument("uvs: row " + std::to_string(c) + " is not finite");
    const auto [it, fresh] = welded.try_emplace({mesh.corners()[c], u, v}, int(mesh.uvs.size() / 2));
    if (fresh) mesh.uvs.insert(mesh.uvs.end(), {u, v});
    mesh.uv_indices[c] = it->second;
  }
  mesh.uv_smooth = smooth;
}

namespace {

// Index of edge (a, b) in the sorted edge list of edge_topology (it must be an edge).
std::size_t edge_index(const std::vector<int>& edges, int a, int b) {
  std::size_t lo = 0, hi = edges.size() / 2;
  const std::pair<int, int> key{std::min(a, b), std::max(a, b)};
  while (lo < hi) {
    const std::size_t mid = (lo + hi) / 2;
    if (std::pair<int, int>{edges[2 * mid], edges[2 * mid + 1]} < key) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

}  // namespace

std::vector<double> vertex_sharpness(const ControlMesh& mesh) {
  std::vector<double> sharpness(mesh.vertex_count(), 0.0);
  for (std::size_t k = 0; k < mesh.corner_vertices.size(); ++k) sharpness[mesh.corner_vertices[k]] = mesh.corner_sharpness[k];
  if (!mesh.sharpen_two_edge_vertices) return sharpness;
  const EdgeTopology topo = edge_topology(mesh);
  const std::size_t edge_count = topo.edges.size() / 2;
  std::vector<double> edge_sharpness(edge_count, 0.0);
  for (std::size_t k = 0; k < mesh.crease_sharpness.size(); ++k)
    edge_sharpness[edge_index(topo.edges, mesh.crease_edges[2 * k], mesh.crease_edges[2 * k + 1])] =
        mesh.crease_sharpness[k];
  // Per vertex: how many edges, and the smallest sharpness among them.
  std::vector<int> degree(mesh.vertex_count(), 0);
  std::vector<double> softest(mesh.vertex_count(), std::numeric_limits<double>::infinity());
  for (std::size_t e = 0; e < edge_count; ++e)
    for (int end = 0; end < 2; ++end) {
      const int v = topo.edges[2 * e + end];
      ++degree[v];
      softest[v] = std::min(softest[v], edge_sharpness[e]);
    }
  // Blender's intern/opensubdiv topology_refiner_factory.cc, assignComponentTags (as of 3.x to 5.x).
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v)
    if (degree[v] == 2) sharpness[v] = std::min(sharpness[v] + softest[v], kInfiniteSharpness);
  return sharpness;
}

EdgeTopology edge_topology(const ControlMesh& mesh) {
  const std::vector<HalfEdge> h = half_edges(mesh);
  EdgeTopology t;
  t.face_offsets.push_back(0);
  for (std::size_t i = 0; i < h.size();) {
    std::size_t j = i;
    t.edges.insert(t.edges.end(), {h[i].a, h[i].b});
    for (; j < h.size() && h[j].a == h[i].a && h[j].b == h[i].b; ++j) {
      t.face_of.push_back(h[j].face);
      t.local_of.push_back(h[j].local);
    }
    t.face_offsets.push_back(int(t.face_of.size()));
    i = j;
  }
  return t;
}

}  // namespace deformkit
