#pragma once
// Nearest-triangle queries on a triangle mesh with a normal filter, for the correspondence phase of
// deformation transfer (Sumner and Popovic 2004, section 5): the closest *valid* point (on a
// triangle facing the same side) and the nearest compatible centroid. A k-d tree over the triangle
// centroids (nanoflann) proposes candidates; the closest-point query is exact, because no triangle
// comes nearer to a point than its centroid's distance minus its radius (docs/math/transfer.md,
// "Correspondence").
#include <Eigen/Core>

#include <memory>
#include <vector>

namespace deformkit {

struct TriangleHit {
  int triangle = -1;  // -1: none found
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double distance = 0.0;
};

// The point of triangle (a, b, c) closest to p (Ericson, Real-Time Collision Detection, 5.1.5).
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c);

class TriangleLocator {
 public:
  // points: n x 3, triangles: t x 3 (row-major); degenerate triangles never match.
  TriangleLocator(const std::vector<double>& points, const std::vector<int>& triangles);
  ~TriangleLocator();
  TriangleLocator(TriangleLocator&&) noexcept;
  TriangleLocator& operator=(TriangleLocator&&) noexcept;

  // The closest point to p on a triangle whose unit normal makes an angle under 90 degrees with
  // `normal` (its dot product > 0); any triangle when normal is zero.
  TriangleHit closest_valid_point(const Eigen::Vector3d& p, const Eigen::Vector3d& normal) const;
  // The triangle whose centroid is nearest q among those within max_distance whose normal makes an
  // angle under 90 degrees with `normal`; -1 if none.
  int nearest_compatible_centroid(const Eigen::Vector3d& q, const Eigen::Vector3d& normal, double max_distance) const;

  const Eigen::Vector3d& centroid(int t) const { return centroids_[std::size_t(t)]; }
  const Eigen::Vector3d& normal(int t) const { return normals_[std::size_t(t)]; }
  std::size_t size() const { return centroids_.size(); }

 private:
  struct Tree;
  std::vector<double> points_;
  std::vector<int> triangles_;
  std::vector<Eigen::Vector3d> centroids_, normals_;  // unit normals, zero for degenerate triangles
  double radius_ = 0.0;  // the largest centroid-to-corner distance
  std::unique_ptr<Tree> tree_;
};

}  // namespace deformkit
