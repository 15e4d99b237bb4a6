#include "transfer/triangle_locator.hpp"

#include <nanoflann.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace deformkit {

using Vec3 = Eigen::Vector3d;

Vec3 closest_point_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

namespace {

// nanoflann's dataset interface over the centroids.
struct Centroids {
  const std::vector<Vec3>* c;
  std::size_t kdtree_get_point_count() const { return c->size(); }
  double kdtree_get_pt(std::size_t i, std::size_t d) const { return (*c)[i][Eigen::Index(d)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const { return false; }
};

using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Centroids>, Centroids, 3, unsigned>;

}  // namespace

struct TriangleLocator::Tree {
  Centroids data;
  KdTree index;
  explicit Tree(const std::vector<Vec3>& c) : data{&c}, index(3, data, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {
    index.buildIndex();
  }
};

TriangleLocator::TriangleLocator(const std::vector<double>& points, const std::vector<int>& triangles)
    : points_(points), triangles_(triangles) {
  const std::size_t t = triangles.size() / 3;
  centroids_.resize(t);
  normals_.resize(t);
  for (std::size_t j = 0; j < t; ++j) {
    const int* v = triangles.data() + 3 * j;
    const Vec3 a(points[3 * v[0]], points[3 * v[0] + 1], points[3 * v[0] + 2]);
    const Vec3 b(points[3 * v[1]], points[3 * v[1] + 1], points[3 * v[1] + 2]);
    const Vec3 c(points[3 * v[2]], points[3 * v[2] + 1], points[3 * v[2] + 2]);
    centroids_[j] = (a + b + c) / 3.0;
    const Vec3 n = (b - a).cross(c - a);
    const double len = n.norm();
    normals_[j] = len > 0 ? Vec3(n / len) : Vec3::Zero();
    radius_ = std::max({radius_, (a - centroids_[j]).norm(), (b - centroids_[j]).norm(), (c - centroids_[j]).norm()});
  }
  tree_ = std::make_unique<Tree>(centroids_);
}

TriangleLocator::~TriangleLocator() = default;
TriangleLocator::TriangleLocator(TriangleLocator&&) noexcept = default;
TriangleLocator& TriangleLocator::operator=(TriangleLocator&&) noexcept = default;

TriangleHit TriangleLocator::closest_valid_point(const Vec3& p, const Vec3& normal) const {
  const bool any = normal.squaredNorm() == 0;
  auto valid = [&](std::size_t j) { return normals_[j].squaredNorm() > 0 && (any || normals_[j].dot(normal) > 0); };
  TriangleHit best;
  best.distance = std::numeric_limits<double>::infinity();
  auto consider = [&](std::size_t j) {
    if (!valid(j)) return;
    const int* v = triangles_.data() + 3 * j;
    auto at = [&](int i) { return Vec3(points_[3 * i], points_[3 * i + 1], points_[3 * i + 2]); };
    const Vec3 q = closest_point_on_triangle(p, at(v[0]), at(v[1]), at(v[2]));
    const double d = (q - p).norm();
    if (d < best.distance) best = {int(j), q, d};
  };
  const std::size_t t = size();
  if (t == 0) return {};
  // A first candidate among the nearest centroids, then every triangle that could still be nearer.
  for (std::size_t k = std::min<std::size_t>(16, t);; k = std::min(2 * k, t)) {
    std::vector<unsigned> index(k);
    std::vector<double> d2(k);
    const std::size_t found = tree_->index.knnSearch(p.data(), k, index.data(), d2.data());
    for (std::size_t i = 0; i < found; ++i) consider(index[i]);
    if (best.triangle >= 0 || k == t) break;
  }
  if (best.triangle < 0) return {};
  const double reach = best.distance + radius_;
  std::vector<std::pair<unsigned, double>> near;
  tree_->index.radiusSearch(p.data(), reach * reach, near, nanoflann::SearchParams(32, 0, false));
  for (const auto& hit : near) consider(hit.first);
  return best;
}

int TriangleLocator::nearest_compatible_centroid(const Vec3& q, const Vec3& normal, double max_distance) const {
  const std::size_t t = size();
  auto compatible = [&](std::size_t j) { return normals_[j].dot(normal) > 0; };
  const std::size_t k = std::min<std::size_t>(8, t);
  std::vector<unsigned> index(k);
  std::vector<double> d2(k);
  const std::size_t found = tree_->index.knnSearch(q.data(), k, index.data(), d2.data());
  const double limit = max_distance * max_distance;
  // Sorted nearest first: the first compatible one is the nearest compatible of all.
  for (std::size_t i = 0; i < found; ++i) {
    if (d2[i] > limit) return -1;
    if (compatible(index[i])) return int(index[i]);
  }
  if (found < k || found == t) return -1;
  std::vector<std::pair<unsigned, double>> near;
  tree_->index.radiusSearch(q.data(), limit, near, nanoflann::SearchParams(32, 0, true));
  for (const auto& hit : near)
    if (compatible(hit.first)) return int(hit.first);
  return -1;
}

}  // namespace deformkit
