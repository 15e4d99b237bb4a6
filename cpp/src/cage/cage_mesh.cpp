#include "deformkit/cage/cage_mesh.hpp"

#include "cage/exact_geometry.hpp"

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

// The polygon's vector area, sum (p_i - o) x (p_{i+1} - o), about the centre o of its corners'
// bounding box: the products then round relative to the polygon's size, not its distance from the
// origin, and o does not depend on which corner the face lists first.
Vec3 vector_area(const double* points, const int* corners, int count) {
  Vec3 lo = point(points, corners[0]), hi = lo;
  for (int i = 1; i < count; ++i) lo = lo.cwiseMin(point(points, corners[i])), hi = hi.cwiseMax(point(points, corners[i]));
  const Vec3 o = 0.5 * (lo + hi);
  Vec3 area = Vec3::Zero();
  for (int i = 0; i < count; ++i) area += (point(points, corners[i]) - o).cross(point(points, corners[(i + 1) % count]) - o);
  return area;
}

// The plane a polygon is seen in: along the coordinate axis its vector area leans on most, from
// the side that area points to. Projecting a planar polygon along that axis keeps its shape's
// turns, so every turn below is an exact sign on the input doubles (cage_exact::turn_along).
struct ViewAxis {
  int axis = 0;
  int side = 0;  // +1 or -1; 0 for a polygon of no area
};

ViewAxis view_axis(const Vec3& area) {
  ViewAxis v;
  area.cwiseAbs().maxCoeff(&v.axis);
  v.side = area[v.axis] > 0 ? 1 : area[v.axis] < 0 ? -1 : 0;
  return v;
}

int turn(const Vec3& a, const Vec3& b, const Vec3& c, const ViewAxis& view) {
  return view.side * cage_exact::turn_along(a, b, c, view.axis);
}

// The ear (a, b, c) of `ring` turns the polygon's way and holds none of the ring's other corners,
// on its boundary included (all seen along the view axis): cutting it leaves a simple polygon.
bool is_ear(const double* points, const std::vector<int>& ring, std::size_t i, const ViewAxis& view) {
  const std::size_t n = ring.size();
  const int ia = ring[(i + n - 1) % n], ib = ring[i], ic = ring[(i + 1) % n];
  const Vec3 a = point(points, ia), b = point(points, ib), c = point(points, ic);
  if (degenerate_triangle(a, b, c) || turn(a, b, c, view) <= 0) return false;
  for (const int v : ring) {
    if (v == ia || v == ib || v == ic) continue;
    const Vec3 q = point(points, v);
    if (turn(a, b, q, view) >= 0 && turn(b, c, q, view) >= 0 && turn(c, a, q, view) >= 0) return false;
  }
  return true;
}

}  // namespace

std::vector<CageTriangle> split_polygon(const double* points, const int* corners, int count) {
  std::vector<int> ring(corners, corners + count);
  std::vector<CageTriangle> out;
  const ViewAxis view = view_axis(vector_area(points, corners, count));
  while (ring.size() > 3) {
    const std::size_t n = ring.size();
    std::size_t best = n;
    double best_length = 0.0;
    std::pair<int, int> best_pair{0, 0};
    for (std::size_t i = 0; i < n; ++i) {
      const int prev = ring[(i + n - 1) % n], next = ring[(i + 1) % n];
      const Vec3 a = point(points, prev), c = point(points, next);
      if (!is_ear(points, ring, i, view)) continue;
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

CageMesh::CageMesh(PolygonMesh polygons) : polygons_(std::move(polygons)) {
  require_distinct_corners(polygons_);
  const double* p = polygons_.points().data();
  const std::size_t faces = polygons_.face_count();
  // Per face: zero area, and a split into triangles of non-zero area.
  for (std::size_t f = 0; f < faces; ++f) {
    const int* c = polygons_.face(f);
    const int k = polygons_.face_size(f);
    double longest = 0.0;
    for (int i = 0; i < k; ++i) longest = std::max(longest, (point(p, c[(i + 1) % k]) - point(p, c[i])).squaredNorm());
    if (!(0.5 * vector_area(p, c, k).norm() > kDegenerate * longest))
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
  if (hit[0] < 0) return;
  const int f = triangle_face_[std::size_t(hit[0])], g = triangle_face_[std::size_t(hit[1])];
  if (f == g)  // a polygon folded so far out of its plane that two of its triangles meet
    throw std::invalid_argument("faces: face " + std::to_string(f) + " intersects itself (the cage intersects itself)");
  throw std::invalid_argument("faces: faces " + std::to_string(f) + " and " + std::to_string(g) +
                              " intersect (the cage intersects itself)");
}

}  // namespace deformkit
