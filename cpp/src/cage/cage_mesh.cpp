#include "deformkit/cage/cage_mesh.hpp"

#include "deformkit/core/types.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

namespace deformkit {

namespace {

// A triangle this thin (area over squared longest edge) has no direction a coordinate could use.
constexpr double kDegenerate = 1e-12;

Vec3 point(const double* p, int v) { return Vec3(p[3 * v], p[3 * v + 1], p[3 * v + 2]); }

bool degenerate_triangle(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double longest = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
  return !(0.5 * (b - a).cross(c - a).norm() > kDegenerate * longest);
}

CageTriangle starting_at_smallest(int a, int b, int c) {
  if (a < b && a < c) return {a, b, c};
  if (b < a && b < c) return {b, c, a};
  return {c, a, b};
}

std::string edge_name(int a, int b) { return "(" + std::to_string(a) + ", " + std::to_string(b) + ")"; }

// Signed volume (times 6) of the tetrahedron p, q, r, s.
double orient(const Vec3& p, const Vec3& q, const Vec3& r, const Vec3& s) { return (q - p).dot((r - p).cross(s - p)); }

// The segment q0 q1 crosses the triangle's interior (strictly: touching is not counted).
bool segment_crosses(const Vec3& q0, const Vec3& q1, const Vec3& a, const Vec3& b, const Vec3& c) {
  const double s0 = orient(a, b, c, q0), s1 = orient(a, b, c, q1);
  if (!((s0 < 0 && s1 > 0) || (s0 > 0 && s1 < 0))) return false;
  const double o1 = orient(q0, q1, a, b), o2 = orient(q0, q1, b, c), o3 = orient(q0, q1, c, a);
  return (o1 > 0 && o2 > 0 && o3 > 0) || (o1 < 0 && o2 < 0 && o3 < 0);
}


// The ear (a, b, c) of `ring` is convex along the polygon's area vector and holds none of the
// ring's other corners (seen along that vector): cutting it leaves a simple polygon.
bool is_ear(const double* points, const std::vector<int>& ring, std::size_t i, const Vec3& area) {
  const std::size_t n = ring.size();
  const int ia = ring[(i + n - 1) % n], ib = ring[i], ic = ring[(i + 1) % n];
  const Vec3 a = point(points, ia), b = point(points, ib), c = point(points, ic);
  if (degenerate_triangle(a, b, c) || !((b - a).cross(c - b).dot(area) > 0.0)) return false;
  for (const int v : ring) {
    if (v == ia || v == ib || v == ic) continue;
    const Vec3 q = point(points, v);
    if ((b - a).cross(q - a).dot(area) >= 0 && (c - b).cross(q - b).dot(area) >= 0 && (a - c).cross(q - c).dot(area) >= 0)
      return false;
  }
  return true;
}

}  // namespace

std::vector<CageTriangle> split_polygon(const double* points, const int* corners, int count) {
  std::vector<int> ring(corners, corners + count);
  std::vector<CageTriangle> out;
  Vec3 area = Vec3::Zero();
  for (int i = 0; i < count; ++i) area += point(points, corners[i]).cross(point(points, corners[(i + 1) % count]));
  while (ring.size() > 3) {
    const std::size_t n = ring.size();
    std::size_t best = n;
    double best_length = 0.0;
    std::pair<int, int> best_pair{0, 0};
    for (std::size_t i = 0; i < n; ++i) {
      const int prev = ring[(i + n - 1) % n], next = ring[(i + 1) % n];
      const Vec3 a = point(points, prev), c = point(points, next);
      if (!is_ear(points, ring, i, area)) continue;
      const double length = (c - a).squaredNorm();
      const std::pair<int, int> pair{std::min(prev, next), std::max(prev, next)};
      // A quad's two ears on one diagonal cut the same two triangles: either may be taken.
      if (best == n || length < best_length || (length == best_length && pair < best_pair)) {
        best = i, best_length = length, best_pair = pair;
      }
    }
    if (best == n) return {};
    out.push_back(starting_at_smallest(ring[(best + n - 1) % n], ring[best], ring[(best + 1) % n]));
    ring.erase(ring.begin() + std::ptrdiff_t(best));
  }
  if (degenerate_triangle(point(points, ring[0]), point(points, ring[1]), point(points, ring[2]))) return {};
  out.push_back(starting_at_smallest(ring[0], ring[1], ring[2]));
  std::sort(out.begin(), out.end());
  return out;
}

std::array<int, 2> first_intersecting_triangles(const std::vector<double>& points,
                                                const std::vector<CageTriangle>& triangles) {
  const double* p = points.data();
  const std::size_t t = triangles.size();
  std::vector<Vec3> lo(t), hi(t), normal(t);
  for (std::size_t i = 0; i < t; ++i) {
    const Vec3 a = point(p, triangles[i][0]), b = point(p, triangles[i][1]), c = point(p, triangles[i][2]);
    lo[i] = a.cwiseMin(b).cwiseMin(c);
    hi[i] = a.cwiseMax(b).cwiseMax(c);
    normal[i] = (b - a).cross(c - a).normalized();
  }
  for (std::size_t i = 0; i < t; ++i)
    for (std::size_t j = i + 1; j < t; ++j) {
      if ((lo[i].array() > hi[j].array()).any() || (lo[j].array() > hi[i].array()).any()) continue;
      const CageTriangle& A = triangles[i];
      const CageTriangle& B = triangles[j];
      int shared = 0;
      for (int u = 0; u < 3; ++u) shared += A[u] == B[0] || A[u] == B[1] || A[u] == B[2];
      const Vec3 a[3] = {point(p, A[0]), point(p, A[1]), point(p, A[2])};
      const Vec3 b[3] = {point(p, B[0]), point(p, B[1]), point(p, B[2])};
      bool hit = false;
      if (shared == 3) {
        hit = true;
      } else if (shared == 2) {
        // Neighbours across an edge overlap only when folded flat onto each other.
        hit = normal[i].dot(normal[j]) < -1.0 + 1e-12;
      } else if (shared == 1) {
        // Edges through the shared vertex meet the other triangle's plane there only: the
        // opposite edges are the ones that can cross.
        int ai = 0, bi = 0;
        for (int u = 0; u < 3; ++u) {
          if (A[u] == B[0] || A[u] == B[1] || A[u] == B[2]) ai = u;
          if (B[u] == A[0] || B[u] == A[1] || B[u] == A[2]) bi = u;
        }
        hit = segment_crosses(a[(ai + 1) % 3], a[(ai + 2) % 3], b[0], b[1], b[2]) ||
              segment_crosses(b[(bi + 1) % 3], b[(bi + 2) % 3], a[0], a[1], a[2]);
      } else {
        for (int u = 0; u < 3 && !hit; ++u)
          hit = segment_crosses(a[u], a[(u + 1) % 3], b[0], b[1], b[2]) ||
                segment_crosses(b[u], b[(u + 1) % 3], a[0], a[1], a[2]);
      }
      if (hit) return {int(i), int(j)};
    }
  return {-1, -1};
}

CageMesh::CageMesh(PolygonMesh polygons) : polygons_(std::move(polygons)) {
  require_distinct_corners(polygons_);
  const double* p = polygons_.points().data();
  const std::size_t faces = polygons_.face_count();
  // Per face: zero area, and a split into triangles of non-zero area.
  for (std::size_t f = 0; f < faces; ++f) {
    const int* c = polygons_.face(f);
    const int k = polygons_.face_size(f);
    Vec3 area = Vec3::Zero();
    double longest = 0.0;
    for (int i = 0; i < k; ++i) {
      const Vec3 a = point(p, c[i]), b = point(p, c[(i + 1) % k]);
      area += a.cross(b);
      longest = std::max(longest, (b - a).squaredNorm());
    }
    if (!(0.5 * area.norm() > kDegenerate * longest))
      throw std::invalid_argument("faces: face " + std::to_string(f) + " has zero area (degenerate)");
    const std::vector<CageTriangle> split = split_polygon(p, c, k);
    if (split.empty())
      throw std::invalid_argument("faces: face " + std::to_string(f) +
                                  " cannot be split into triangles of non-zero area (degenerate)");
    for (const CageTriangle& t : split) {
      triangles_.push_back(t);
      triangle_face_.push_back(int(f));
    }
  }
  // Edges: each must join exactly two faces that run it in opposite directions.
  struct Use {
    int face, from;
  };
  std::unordered_map<std::uint64_t, std::vector<Use>> uses;
  auto key = [](int a, int b) { return (std::uint64_t(std::min(a, b)) << 32) | std::uint32_t(std::max(a, b)); };
  for (std::size_t f = 0; f < faces; ++f) {
    const int* c = polygons_.face(f);
    const int k = polygons_.face_size(f);
    for (int i = 0; i < k; ++i) uses[key(c[i], c[(i + 1) % k])].push_back({int(f), c[i]});
  }
  for (std::size_t f = 0; f < faces; ++f) {
    const int* c = polygons_.face(f);
    const int k = polygons_.face_size(f);
    for (int i = 0; i < k; ++i) {
      const int a = c[i], b = c[(i + 1) % k];
      const std::vector<Use>& u = uses[key(a, b)];
      if (u.size() > 2) {
        std::string list;
        for (std::size_t j = 0; j < u.size(); ++j) list += (j ? ", " : "") + std::to_string(u[j].face);
        throw std::invalid_argument("faces: edge " + edge_name(a, b) + " is shared by " + std::to_string(u.size()) +
                                    " faces (" + list + "): the cage is non-manifold there");
      }
      if (u.size() == 1)
        throw std::invalid_argument("faces: edge " + edge_name(a, b) + " of face " + std::to_string(f) +
                                    " belongs to no other face: the cage is open (it must be closed)");
      if (u[0].from == u[1].from)
        throw std::invalid_argument("faces: edge " + edge_name(a, b) + " runs the same way in faces " +
                                    std::to_string(u[0].face) + " and " + std::to_string(u[1].face) +
                                    ": inconsistent orientation (reverse one of them)");
    }
  }
  // Volume about the bounding box's centre, where the products lose the least to rounding.
  Vec3 lo = point(p, 0), hi = lo;
  double magnitude = 0.0;
  for (std::size_t v = 0; v < vertex_count(); ++v) {
    lo = lo.cwiseMin(point(p, int(v)));
    hi = hi.cwiseMax(point(p, int(v)));
    magnitude = std::max(magnitude, point(p, int(v)).cwiseAbs().maxCoeff());
  }
  const Vec3 centre = 0.5 * (lo + hi);
  const double diagonal = (hi - lo).norm();
  length_scale_ = std::max(diagonal, magnitude);
  double six_volume = 0.0;
  for (const CageTriangle& t : triangles_)
    six_volume += (point(p, t[0]) - centre).dot((point(p, t[1]) - centre).cross(point(p, t[2]) - centre));
  if (!(std::abs(six_volume) > 6.0 * kDegenerate * diagonal * diagonal * diagonal))
    throw std::invalid_argument("faces: the cage encloses no volume");
  if (six_volume < 0) {  // faces point inward: the coordinates assume outward triangles
    flipped_ = true;
    for (CageTriangle& t : triangles_) t = starting_at_smallest(t[0], t[2], t[1]);
    // Sorted again within each polygon: the outward listing of the same cage gives these triangles.
    for (std::size_t begin = 0, end = 0; begin < triangles_.size(); begin = end) {
      while (end < triangles_.size() && triangle_face_[end] == triangle_face_[begin]) ++end;
      std::sort(triangles_.begin() + std::ptrdiff_t(begin), triangles_.begin() + std::ptrdiff_t(end));
    }
  }
  volume_ = std::abs(six_volume) / 6.0;
  const std::array<int, 2> hit = first_intersecting_triangles(polygons_.points(), triangles_);
  if (hit[0] >= 0)
    throw std::invalid_argument("faces: faces " + std::to_string(triangle_face_[hit[0]]) + " and " +
                                std::to_string(triangle_face_[hit[1]]) + " intersect (the cage intersects itself)");
}

}  // namespace deformkit
