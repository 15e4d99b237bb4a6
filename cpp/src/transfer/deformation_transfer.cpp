#include "deformkit/transfer/deformation_transfer.hpp"

#include "core/parallel.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <stdexcept>
#include <string>

namespace deformkit {

namespace {

using Vec3 = Eigen::Vector3d;

Vec3 point(const std::vector<double>& p, int i) { return Vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]); }
Vec3 point(const double* p, int i) { return Vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]); }

// Sumner and Popovic 2004, eq. 1-3: the triangle's edges and its fourth vertex's offset
// n / sqrt(|n|), which scales as the edges do.
Eigen::Matrix3d frame(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e1 = b - a, e2 = c - a, n = e1.cross(e2);
  Eigen::Matrix3d v;
  v << e1, e2, n / std::sqrt(n.norm());
  return v;
}

}  // namespace

DeformationTransfer::DeformationTransfer(const PolygonMesh& source, const std::vector<double>& target_points)
    : source_(source.points()), target_(target_points) {
  const std::size_t n = source.vertex_count();
  if (target_points.size() != source_.size())
    throw std::invalid_argument("target_points: expected " + std::to_string(n) +
                                " points (the source's; the faces are shared), got " +
                                std::to_string(target_points.size() / 3));
  for (std::size_t i = 0; i < target_points.size(); ++i)
    if (!std::isfinite(target_points[i]))
      throw std::invalid_argument("target_points: row " + std::to_string(i / 3) + " is not finite");
  const PolygonMesh tri = source.triangulate();
  triangles_ = tri.corners();
  const std::size_t t = triangle_count();
  frame_inverse_.resize(t);
  tangent_.resize(t);
  // The target's gradient operator, sqrt(area)-weighted: rows 3j..3j+2 give the gradient of a
  // piecewise-linear function on triangle j (hat gradients n x (p_k+2 - p_k+1) / (2 area)).
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(9 * t);
  for (std::size_t j = 0; j < t; ++j) {
    const int* v = triangles_.data() + 3 * j;
    const Eigen::Matrix3d s = frame(point(source_, v[0]), point(source_, v[1]), point(source_, v[2]));
    const double s_area = 0.5 * s.col(0).cross(s.col(1)).norm();
    const Vec3 p[3] = {point(target_, v[0]), point(target_, v[1]), point(target_, v[2])};
    const Vec3 nn = (p[1] - p[0]).cross(p[2] - p[0]);
    const double twice_area = nn.norm();
    if (!(s_area > 0) || !(twice_area > 0))
      throw std::invalid_argument(std::string(s_area > 0 ? "target_faces" : "source_faces") + ": triangle " +
                                  std::to_string(j) + " (vertices " + std::to_string(v[0]) + ", " + std::to_string(v[1]) +
                                  ", " + std::to_string(v[2]) + ") has zero area");
    frame_inverse_[j] = s.inverse();
    const Vec3 unit = nn / twice_area;
    const double w = std::sqrt(0.5 * twice_area);
    tangent_[j] = w * (Eigen::Matrix3d::Identity() - unit * unit.transpose());
    for (int k = 0; k < 3; ++k) {
      const Vec3 g = w * unit.cross(p[(k + 2) % 3] - p[(k + 1) % 3]) / twice_area;
      for (int c = 0; c < 3; ++c) entries.emplace_back(Eigen::Index(3 * j + c), v[k], g[c]);
    }
  }
  SparseMatrix m(Eigen::Index(3 * t), Eigen::Index(n));
  m.setFromTriplets(entries.begin(), entries.end());
  // Gradients fix a shape up to a translation per connected part: its first vertex is anchored.
  int parts = 0;
  const std::vector<int> part = connected_components(tri, &parts);
  std::vector<char> fixed(n, 0), seen(std::size_t(parts), 0);
  for (std::size_t i = 0; i < n; ++i)
    if (!seen[std::size_t(part[i])]) {
      seen[std::size_t(part[i])] = 1;
      fixed[i] = 1;
      anchors_.push_back(int(i));
    }
  system_ = ConstrainedQuadratic::least_squares(m, UnknownSplit(fixed), SoftConstraints{});
  if (!system_.factorised())
    throw std::invalid_argument("target_points: the target's gradient system could not be factorised (degenerate geometry)");
}

// Per pose: the source's gradients S_j = V'_j V_j^-1, the target's wanted gradients of each
// coordinate P_j S_j^T e_c (the tangential part: Botsch et al. 2006, eq. 6), one least-squares solve.
void DeformationTransfer::transfer(const double* poses, std::size_t k, double* out) const {
  const std::size_t n = vertex_count(), t = triangle_count();
  for (std::size_t i = 0; i < 3 * n * k; ++i)
    if (!std::isfinite(poses[i]))
      throw std::invalid_argument("source_pose: pose " + std::to_string(i / (3 * n)) + ", row " +
                                  std::to_string((i % (3 * n)) / 3) + " is not finite");
  Eigen::MatrixXd r(Eigen::Index(3 * t), Eigen::Index(3 * k));
  parallel_blocks(t, [&](std::size_t begin, std::size_t end) {
    for (std::size_t j = begin; j < end; ++j) {
      const int* v = triangles_.data() + 3 * j;
      for (std::size_t q = 0; q < k; ++q) {
        const double* pose = poses + 3 * n * q;
        const Eigen::Matrix3d moved = frame(point(pose, v[0]), point(pose, v[1]), point(pose, v[2]));
        const Eigen::Matrix3d wanted = tangent_[j] * (moved * frame_inverse_[j]).transpose();
        r.block<3, 3>(Eigen::Index(3 * j), Eigen::Index(3 * q)) = wanted;
      }
    }
  });
  // A triangle the pose collapses has no frame (its fourth vertex is n / sqrt(0)).
  for (std::size_t q = 0; q < k; ++q)
    for (std::size_t j = 0; j < t; ++j)
      if (!r.block<3, 3>(Eigen::Index(3 * j), Eigen::Index(3 * q)).allFinite())
        throw std::invalid_argument("source_pose: pose " + std::to_string(q) + " collapses triangle " + std::to_string(j) +
                                    " to zero area: it has no deformation gradient");
  Eigen::MatrixXd fixed(Eigen::Index(anchors_.size()), Eigen::Index(3 * k));
  for (std::size_t a = 0; a < anchors_.size(); ++a)
    for (std::size_t q = 0; q < k; ++q)
      for (int c = 0; c < 3; ++c) {
        const std::size_t i = std::size_t(anchors_[a]);
        fixed(Eigen::Index(a), Eigen::Index(3 * q + c)) = target_[3 * i + c] + poses[3 * n * q + 3 * i + c] - source_[3 * i + c];
      }
  const Eigen::MatrixXd all = system_.assemble(system_.solve_free(r, fixed, Eigen::MatrixXd()), fixed);
  for (std::size_t q = 0; q < k; ++q)
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) out[3 * n * q + 3 * i + c] = all(Eigen::Index(i), Eigen::Index(3 * q + c));
}

}  // namespace deformkit
