// generate_cage: the options checked, the wrap coarsened until its outward simplification meets
// the face budget, the result checked exactly, and a box (or a tetrahedron) around the mesh when
// nothing finer fits (docs/cage.md, "Generated cages").
#include "deformkit/cage/generate_cage.hpp"

#include "cage/generate_cage_steps.hpp"
#include "deformkit/cage/cage_mesh.hpp"
#include "deformkit/core/types.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>

namespace deformkit {

namespace {

using cage_generation::TriangleCage;

std::string str(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

struct Extent {
  Vec3 lo, hi;
  double diagonal() const { return (hi - lo).norm(); }
};

Extent extent_of(const std::vector<double>& p) {
  Extent e{Vec3::Constant(INFINITY), Vec3::Constant(-INFINITY)};
  for (std::size_t i = 0; i + 2 < p.size(); i += 3) {
    const Vec3 x(p[i], p[i + 1], p[i + 2]);
    e.lo = e.lo.cwiseMin(x), e.hi = e.hi.cwiseMax(x);
  }
  return e;
}

void check_input(const std::vector<double>& points, const std::vector<std::array<int, 3>>& triangles,
                 const CageGenerationOptions& o) {
  if (points.empty() || points.size() % 3 != 0)
    throw std::invalid_argument("points: expected at least one point (n, 3), got " + std::to_string(points.size() / 3) +
                                " points");
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!std::isfinite(points[i]))
      throw std::invalid_argument("points: expected finite coordinates, got " + str(points[i]) + " at row " +
                                  std::to_string(i / 3));
  const int n = int(points.size() / 3);
  for (std::size_t f = 0; f < triangles.size(); ++f)
    for (int v : triangles[f])
      if (v < 0 || v >= n)
        throw std::invalid_argument("faces: expected vertex indices in 0.." + std::to_string(n - 1) + ", got " +
                                    std::to_string(v) + " in face " + std::to_string(f));
  if (o.max_faces < 4)
    throw std::invalid_argument("max_faces: expected at least 4 (a closed cage has at least a tetrahedron's 4 faces), got " +
                                std::to_string(o.max_faces));
  if (!std::isfinite(o.offset) || o.offset < 0)
    throw std::invalid_argument("offset: expected a positive finite distance, got " + str(o.offset));
  if (!std::isfinite(o.alpha) || o.alpha < 0)
    throw std::invalid_argument("alpha: expected a positive finite length, got " + str(o.alpha));
}

// The box [lo, hi] as 12 outward triangles, or a tetrahedron around it when fewer faces are allowed.
TriangleCage box_cage(const Vec3& lo, const Vec3& hi, int max_faces) {
  TriangleCage c;
  if (max_faces >= 12) {
    for (int i = 0; i < 8; ++i)
      c.points.insert(c.points.end(), {(i & 1) ? hi[0] : lo[0], (i & 2) ? hi[1] : lo[1], (i & 4) ? hi[2] : lo[2]});
    c.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                   {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    return c;
  }
  // The corner tetrahedron x, y, z >= 0, x + y + z <= 3.5 s holds the cube [0, s]^3 strictly inside.
  const double s = (hi - lo).maxCoeff() * 3.5;
  c.points = {lo[0], lo[1], lo[2], lo[0] + s, lo[1], lo[2], lo[0], lo[1] + s, lo[2], lo[0], lo[1], lo[2] + s};
  c.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return c;
}

// Whether the deformers' own split of quad (a, d, b, c) gives back the triangles (a, b, c), (b, a, d).
bool splits_back(const std::vector<double>& p, const std::array<int, 4>& quad, int a, int b) {
  const auto tris = split_polygon(p.data(), quad.data(), 4);
  if (tris.size() != 2) return false;
  for (const auto& t : tris)
    if (std::count(t.begin(), t.end(), a) + std::count(t.begin(), t.end(), b) != 2) return false;
  return true;
}

// Pairs of triangles merged into quads, flattest pairs first, where the quad is planar within
// `max_angle` and the cage deformers' split of it (split_polygon) is the pair itself, so the
// cage they see is the checked triangle cage.
GeneratedCage merge_quads(const TriangleCage& c, double max_angle) {
  const auto& p = c.points;
  auto normal = [&](const std::array<int, 3>& t) {
    const Vec3 a(p[3 * t[0]], p[3 * t[0] + 1], p[3 * t[0] + 2]), b(p[3 * t[1]], p[3 * t[1] + 1], p[3 * t[1] + 2]),
        d(p[3 * t[2]], p[3 * t[2] + 1], p[3 * t[2] + 2]);
    return (b - a).cross(d - a).normalized();
  };
  std::map<std::pair<int, int>, std::pair<int, int>> edge_face;  // directed edge -> (triangle, corner)
  for (std::size_t t = 0; t < c.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) edge_face[{c.triangles[t][k], c.triangles[t][(k + 1) % 3]}] = {int(t), k};
  std::vector<std::pair<double, std::array<int, 4>>> candidates;  // angle, (t, u, a, b)
  for (const auto& [e, tk] : edge_face) {
    if (e.first > e.second) continue;
    const auto it = edge_face.find({e.second, e.first});
    if (it == edge_face.end()) continue;
    const double angle = std::acos(std::clamp(normal(c.triangles[tk.first]).dot(normal(c.triangles[it->second.first])), -1.0, 1.0));
    if (angle <= max_angle) candidates.push_back({angle, {tk.first, it->second.first, e.first, e.second}});
  }
  std::sort(candidates.begin(), candidates.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  std::vector<char> used(c.triangles.size(), 0);
  std::vector<std::array<int, 4>> quads;
  for (const auto& [angle, q] : candidates) {
    const auto [t, u, a, b] = q;
    if (used[t] || used[u]) continue;
    const auto& tt = c.triangles[t];
    const auto& tu = c.triangles[u];
    const int third_t = tt[0] + tt[1] + tt[2] - a - b, third_u = tu[0] + tu[1] + tu[2] - a - b;
    const std::array<int, 4> quad{a, third_u, b, third_t};  // t runs a -> b, so u runs b -> a
    if (!splits_back(p, quad, a, b)) continue;
    used[t] = used[u] = 1;
    quads.push_back(quad);
  }
  GeneratedCage g;
  g.points = p;
  g.offsets.push_back(0);
  for (const auto& q : quads) {
    g.corners.insert(g.corners.end(), q.begin(), q.end());
    g.offsets.push_back(std::int64_t(g.corners.size()));
  }
  for (std::size_t t = 0; t < c.triangles.size(); ++t)
    if (!used[t]) {
      g.corners.insert(g.corners.end(), c.triangles[t].begin(), c.triangles[t].end());
      g.offsets.push_back(std::int64_t(g.corners.size()));
    }
  return g;
}

// Closed, manifold, oriented and free of self-intersections (CageMesh's checks) and around the input.
bool is_valid_cage(const TriangleCage& c, const std::vector<double>& points,
                   const std::vector<std::array<int, 3>>& triangles, int max_faces) {
  if (c.triangles.empty() || int(c.triangles.size()) > max_faces) return false;
  std::vector<std::int64_t> corners, offsets{0};
  for (const auto& t : c.triangles) {
    corners.insert(corners.end(), t.begin(), t.end());
    offsets.push_back(std::int64_t(corners.size()));
  }
  try {
    const CageMesh checked(PolygonMesh(c.points.data(), c.points.size() / 3, corners, offsets));
    if (checked.flipped()) return false;
  } catch (const std::invalid_argument&) {
    return false;
  }
  return cage_generation::strictly_encloses(c, points, triangles);
}

}  // namespace

GeneratedCage generate_cage(const std::vector<double>& points, const std::vector<std::array<int, 3>>& triangles,
                            const CageGenerationOptions& options) {
  check_input(points, triangles, options);
  const Extent e = extent_of(points);
  const double magnitude = std::max(e.lo.cwiseAbs().maxCoeff(), e.hi.cwiseAbs().maxCoeff());
  // The length defaults are relative to: the diagonal, or for a point (or nearly one, next to its
  // coordinates' size) a length its coordinates can still resolve.
  double length = std::max(e.diagonal(), 1e-6 * magnitude);
  if (!(length > 0)) length = 1.0;
  if (!std::isfinite(length)) throw std::invalid_argument("points: the coordinates' extent overflows a double");
  const double offset = options.offset > 0 ? options.offset : length / 100;
  if (offset < 1e-9 * std::max(length, magnitude))
    throw std::invalid_argument("offset: expected at least " + str(1e-9 * std::max(length, magnitude)) +
                                " (1e-9 of the mesh's size, below which the cage's coordinates cannot be told apart), got " + str(offset));
  // The wrap's work grows with (its size / alpha)^2, its size being the mesh's and the offset's.
  const double size = e.diagonal() + 2 * offset;
  // A small budget cannot follow small features: a coarser wrap leaves it a tighter cage (measured
  // on the shared cages, docs/benchmarks.md, "Issue 33 (generated cages)").
  const double divisions = std::clamp(1.2 * std::sqrt(double(options.max_faces)), 4.0, 20.0);
  double alpha = options.alpha > 0 ? options.alpha : size / divisions;
  if (alpha < 1e-3 * size)
    throw std::invalid_argument("alpha: expected at least " + str(1e-3 * size) +
                                " (1/1000 of the diagonal of the mesh grown by offset: finer wraps take minutes), got " + str(alpha));

  TriangleCage cage;
  std::size_t wrap_faces = 0;
  bool found = false;
  double used_alpha = alpha;
  // A coarser wrap leaves fewer faces to remove; past the mesh's size it is a blob.
  for (int attempt = 0; attempt < 6 && !found; ++attempt, alpha *= 2) {
    used_alpha = alpha;
    try {
      const TriangleCage wrap = cage_generation::alpha_wrap(points, triangles, alpha, offset);
      wrap_faces = wrap.triangles.size();
      cage = cage_generation::simplify_outward(wrap, options.max_faces);
      found = is_valid_cage(cage, points, triangles, options.max_faces);
    } catch (const std::logic_error&) {  // a CGAL precondition or assertion: this attempt failed, not the call
      found = false;
    }
  }
  if (!found) cage = box_cage(e.lo - Vec3::Constant(offset), e.hi + Vec3::Constant(offset), options.max_faces);
  GeneratedCage out = options.quads ? merge_quads(cage, 30.0 * M_PI / 180.0) : merge_quads(cage, -1.0);
  out.wrap_faces = wrap_faces;
  out.alpha = used_alpha;
  out.offset = offset;
  return out;
}

}  // namespace deformkit
