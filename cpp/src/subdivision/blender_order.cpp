#include "deformkit/subdivision/blender_order.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace deformkit {

namespace {

std::int64_t pair_key(int a, int b, std::size_t n) {
  if (a > b) std::swap(a, b);
  return std::int64_t(a) * std::int64_t(n) + b;
}

// Blender's numbering at one level. Places are ptex grid points (x, y): a quad's grid has n = 2^level
// steps a side, (0,0) at corner 0, x towards corner 1; an n-gon's sub-quad j has m = n / 2 steps,
// (0,0) at corner j, (m,0) the midpoint of edge j, (m,m) the centre.
struct Layout {
  const ControlMesh& mesh;
  const int* edges;
  std::unordered_map<std::int64_t, int> edge_of;  // vertex pair -> Blender edge
  std::vector<int> corner_edge;                   // per control corner: the edge to the next corner
  std::vector<int> first_corner;                  // per face: its first corner there
  std::vector<int> inner_start;                   // per face: its first inner vertex
  int n = 0, m = 0;
  int edge_start = 0;                             // first edge vertex: after the control vertices

  // The vertex `d` (0..n) steps from `a` along control edge e, from a to b.
  int on_edge(int e, int a, int b, int d) const {
    if (d == 0) return a;
    if (d == n) return b;
    return edge_start + e * (n - 1) + (edges[2 * e] == a ? d - 1 : n - 1 - d);
  }
  // The same along the edge from corner j of face f to corner j + 1.
  int on_side(const int* c, const int* e, int k, int j, int d) const { return on_edge(e[j], c[j], c[(j + 1) % k], d); }

  int in_quad(const int* c, const int* e, int x, int y, int start) const {
    if (x > 0 && x < n && y > 0 && y < n) return start + (y - 1) * (n - 1) + (x - 1);
    if (y == 0) return on_side(c, e, 4, 0, x);
    if (y == n) return on_side(c, e, 4, 2, n - x);
    return x == n ? on_side(c, e, 4, 1, y) : on_side(c, e, 4, 3, n - y);
  }

  int in_ngon(const int* c, const int* e, int k, int j, int x, int y, int start) const {
    const int prev = (j + k - 1) % k, per_corner = (m - 1) * m;
    if (x == m && y == m) return start;
    if (y == 0) return on_side(c, e, k, j, x);
    if (x == 0) return on_side(c, e, k, prev, n - y);
    if (y == m) return start + 1 + prev * per_corner + (x - 1) * m + (m - 1);  // sub-quad j - 1's x = m side
    return start + 1 + j * per_corner + (y - 1) * m + (x - 1);
  }

  int at(std::size_t f, int j, int x, int y) const {
    const int k = mesh.face_size(f);
    const int* c = mesh.polygons.face(f);
    const int* e = corner_edge.data() + first_corner[f];
    return k == 4 ? in_quad(c, e, x, y, inner_start[f]) : in_ngon(c, e, k, j, x, y, inner_start[f]);
  }
};

struct Cell {
  int j, x, y;  // sub-quad (0 for a quad) and lower-left grid point
};

// A face's cells in Blender's face order (subdiv_foreach's loops pass): a quad's inner cells by
// rows, then the ring along each edge from its corner; an n-gon's inner cells of every sub-quad,
// the cells between sub-quads, those at the centre, then the ring of each corner.
std::vector<Cell> face_cells(int k, int n, int m) {
  std::vector<Cell> out;
  if (k == 4) {
    for (int y = 1; y < n - 1; ++y)
      for (int x = 1; x < n - 1; ++x) out.push_back({0, x, y});
    for (int i = 0; i < n - 1; ++i) out.push_back({0, i, 0});
    for (int i = 0; i < n - 1; ++i) out.push_back({0, n - 1, i});
    for (int i = 0; i < n - 1; ++i) out.push_back({0, n - 1 - i, n - 1});
    for (int i = 0; i < n - 1; ++i) out.push_back({0, 0, n - 1 - i});
    return out;
  }
  for (int j = 0; j < k; ++j)
    for (int y = 1; y < m - 1; ++y)
      for (int x = 1; x < m; ++x) out.push_back({j, x, y});
  for (int j = 0; j < k; ++j)
    for (int row = 1; row < m - 1; ++row) out.push_back({(j + 1) % k, row, m - 1});
  if (m >= 2)
    for (int j = 0; j < k; ++j) out.push_back({j, m - 1, m - 1});
  for (int j = 0; j < k; ++j) {
    for (int i = 0; i < m; ++i) out.push_back({j, i, 0});
    for (int i = 1; i < m; ++i) out.push_back({j, 0, i});
  }
  return out;
}

// A face's inner edges in Blender's order (subdiv_foreach's edges pass), as pairs of grid points.
using Span = std::array<int, 5>;  // sub-quad, x0, y0, x1, y1
std::vector<Span> face_edges(int k, int n, int m) {
  std::vector<Span> out;
  // The edges between grid points lo..hi (both axes): the first row, then columns and rows up.
  const auto grid = [&](int j, int lo, int hi_x, int hi_y) {
    for (int x = lo; x < hi_x; ++x) out.push_back({j, x, lo, x + 1, lo});
    for (int y = lo; y < hi_y; ++y) {
      for (int x = lo; x <= hi_x; ++x) out.push_back({j, x, y, x, y + 1});
      for (int x = lo; x < hi_x; ++x) out.push_back({j, x, y + 1, x + 1, y + 1});
    }
  };
  if (k == 4) {
    grid(0, 1, n - 1, n - 1);
    for (int i = 1; i < n; ++i) out.push_back({0, i, 0, i, 1});
    for (int i = 1; i < n; ++i) out.push_back({0, n, i, n - 1, i});
    for (int i = 1; i < n; ++i) out.push_back({0, n - i, n, n - i, n - 1});
    for (int i = 1; i < n; ++i) out.push_back({0, 0, n - i, 1, n - i});
    return out;
  }
  for (int j = 0; j < k; ++j) grid(j, 1, m, m - 1);
  for (int j = 0; j < k; ++j)
    for (int row = 1; row < m; ++row) out.push_back({(j + 1) % k, row, m, row, m - 1});
  if (m >= 2)
    for (int j = 0; j < k; ++j) out.push_back({j, m, m, m, m - 1});
  for (int j = 0; j < k; ++j) {
    for (int i = 1; i <= m; ++i) out.push_back({j, i, 0, i, 1});
    for (int i = 1; i < m; ++i) out.push_back({j, 0, i, 1, i});
  }
  return out;
}

std::array<int, 4> sorted(std::array<int, 4> q) {
  std::sort(q.begin(), q.end());
  return q;
}

int grid_step(double t, int size) { return int(std::lround(t * size)); }

Layout make_layout(const Subdivider& subdivider, const int* edges, std::size_t edge_count) {
  const ControlMesh& mesh = subdivider.control();
  if (mesh.scheme != SubdivisionScheme::CatmullClark)
    throw std::invalid_argument("scheme: Blender's order is defined for Catmull-Clark only, got " +
                                scheme_name(mesh.scheme));
  const std::size_t nv = mesh.vertex_count();
  Layout layout{mesh, edges, {}, {}, {}, {}, 1 << subdivider.level(), 1 << (subdivider.level() - 1), int(nv)};
  for (std::size_t e = 0; e < edge_count; ++e) {
    const int a = edges[2 * e], b = edges[2 * e + 1];
    if (a < 0 || b < 0 || std::size_t(a) >= nv || std::size_t(b) >= nv || a == b)
      throw std::invalid_argument("edges: edge " + std::to_string(e) + " (" + std::to_string(a) + ", " +
                                  std::to_string(b) + ") is not a pair of distinct vertices 0.." +
                                  std::to_string(nv - 1));
    if (!layout.edge_of.emplace(pair_key(a, b, nv), int(e)).second)
      throw std::invalid_argument("edges: edge " + std::to_string(e) + " repeats an earlier edge");
  }
  int next = int(nv + edge_count * std::size_t(layout.n - 1));
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const int k = mesh.face_size(f);
    const int* c = mesh.polygons.face(f);
    layout.first_corner.push_back(int(layout.corner_edge.size()));
    for (int j = 0; j < k; ++j) {
      const auto found = layout.edge_of.find(pair_key(c[j], c[(j + 1) % k], nv));
      if (found == layout.edge_of.end())
        throw std::invalid_argument("edges: the edge (" + std::to_string(c[j]) + ", " +
                                    std::to_string(c[(j + 1) % k]) + ") of face " + std::to_string(f) + " is missing");
      layout.corner_edge.push_back(found->second);
    }
    layout.inner_start.push_back(next);
    next += k == 4 ? (layout.n - 1) * (layout.n - 1) : 1 + k * (layout.m - 1) * layout.m;
  }
  if (std::size_t(next) != subdivider.vertex_count())
    throw std::invalid_argument("edges: " + std::to_string(edge_count) + " edges, more than the faces have " +
                                "(loose edges are not subdivided)");
  return layout;
}

}  // namespace

BlenderOrder blender_order(const Subdivider& subdivider, const int* edges, std::size_t edge_count) {
  const Layout layout = make_layout(subdivider, edges, edge_count);
  const ControlMesh& mesh = layout.mesh;
  const int n = layout.n, m = layout.m;
  std::vector<int> ptex_face, ptex_corner;  // ptex face -> control face, sub-quad
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const int k = mesh.face_size(f);
    for (int j = 0; j < (k == 4 ? 1 : k); ++j) ptex_face.push_back(int(f)), ptex_corner.push_back(j);
  }
  BlenderOrder out;
  const std::vector<PtexPoint> params = subdivider.vertex_parameters();
  out.vertex.resize(params.size());
  std::vector<char> taken(params.size(), 0);
  for (std::size_t i = 0; i < params.size(); ++i) {
    const PtexPoint& p = params[i];
    const std::size_t f = std::size_t(ptex_face[p.ptex]);
    const int size = mesh.face_size(f) == 4 ? n : m;
    out.vertex[i] = layout.at(f, ptex_corner[p.ptex], grid_step(p.u, size), grid_step(p.v, size));
    if (taken[out.vertex[i]]++)
      throw std::logic_error("blender_order: two vertices at Blender index " + std::to_string(out.vertex[i]));
  }
  for (std::size_t e = 0; e < edge_count; ++e)
    for (int d = 0; d < n; ++d)
      out.edges.insert(out.edges.end(), {layout.on_edge(int(e), edges[2 * e], edges[2 * e + 1], d),
                                         layout.on_edge(int(e), edges[2 * e], edges[2 * e + 1], d + 1)});
  std::vector<std::array<int, 4>> blender_faces;  // Blender's faces, from their first corner
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const int k = mesh.face_size(f);
    for (const Span& s : face_edges(k, n, m))
      out.edges.insert(out.edges.end(), {layout.at(f, s[0], s[1], s[2]), layout.at(f, s[0], s[3], s[4])});
    for (const Cell& c : face_cells(k, n, m))
      blender_faces.push_back({layout.at(f, c.j, c.x, c.y), layout.at(f, c.j, c.x + 1, c.y),
                               layout.at(f, c.j, c.x + 1, c.y + 1), layout.at(f, c.j, c.x, c.y + 1)});
  }
  // Blender's faces by their lowest vertex (counting sort), to find each of ours among a few.
  std::vector<int> bucket(params.size() + 1, 0), by_lowest(blender_faces.size());
  for (const auto& q : blender_faces) ++bucket[*std::min_element(q.begin(), q.end()) + 1];
  for (std::size_t v = 0; v < params.size(); ++v) bucket[v + 1] += bucket[v];
  std::vector<int> fill(bucket.begin(), bucket.end() - 1);
  for (std::size_t b = 0; b < blender_faces.size(); ++b)
    by_lowest[fill[*std::min_element(blender_faces[b].begin(), blender_faces[b].end())]++] = int(b);
  const std::vector<int>& faces = subdivider.faces();
  const std::size_t face_count = faces.size() / 4;
  out.face.assign(face_count, -1);
  out.face_start.resize(face_count);
  for (std::size_t f = 0; f < face_count; ++f) {
    std::array<int, 4> q;
    for (int c = 0; c < 4; ++c) q[c] = out.vertex[faces[4 * f + c]];
    const std::array<int, 4> key = sorted(q);
    for (int i = bucket[key[0]]; i < bucket[key[0] + 1]; ++i)
      if (sorted(blender_faces[by_lowest[i]]) == key) {
        out.face[f] = by_lowest[i];
        out.face_start[f] = int(std::find(q.begin(), q.end(), blender_faces[by_lowest[i]][0]) - q.begin());
        break;
      }
    if (out.face[f] < 0) throw std::logic_error("blender_order: face " + std::to_string(f) + " not found");
  }
  return out;
}

}  // namespace deformkit
