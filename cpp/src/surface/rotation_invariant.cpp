// The rotation-invariant Laplacian editing of Sorkine et al. 2004, sec. 4: the linearised implicit
// transforms as one constrained least-squares system over the 3n coordinates, then passes that
// rotate the differential coordinates without the linearisation's scale.
#include "deformkit/surface/surface_deformer.hpp"

#include <Eigen/Eigenvalues>

namespace deformkit {

namespace {

// Row i of m as coordinates (x0, y0, z0, x1, ...): the unknowns of the implicit-transform system.
Eigen::MatrixXd interleave(const Eigen::Matrix<double, Eigen::Dynamic, 3>& m) {
  Eigen::MatrixXd v(3 * m.rows(), 1);
  for (Eigen::Index i = 0; i < m.rows(); ++i) v.block<3, 1>(3 * i, 0) = m.row(i).transpose();
  return v;
}

}  // namespace

// True if a held component has all its held vertices on one line (or fewer than three of them).
bool SurfaceDeformer::loosely_held(const std::vector<int>& component, int components,
                                   const std::vector<char>& held) const {
  std::vector<std::vector<int>> members(static_cast<std::size_t>(components));
  for (std::size_t v = 0; v < component.size(); ++v)
    if (held[v]) members[component[v]].push_back(int(v));
  for (const auto& list : members) {
    if (list.empty()) continue;  // unheld: fixed as a whole
    Vec3 mean = Vec3::Zero();
    for (int v : list) mean += rest_.row(v).transpose();
    mean /= double(list.size());
    Mat3 cov = Mat3::Zero();
    for (int v : list) cov += (rest_.row(v).transpose() - mean) * (rest_.row(v).transpose() - mean).transpose();
    const Eigen::Vector3d spread = Eigen::SelfAdjointEigenSolver<Mat3>(cov).eigenvalues();  // ascending
    if (list.size() < 3 || !(spread[1] > 1e-12 * spread[2])) return true;
  }
  return false;
}

// Sorkine et al. 2004, sec. 4: each vertex's transform T_i = s I + [h]x + t, fitted by least squares
// to its one-ring, is linear in the unknown positions; the rows T_i(V') delta_i - L(V')_i then
// ask the differential coordinates to follow their own (linearised) rotation and scale.
SparseMatrix SurfaceDeformer::implicit_transform_system() const {
  const Eigen::Index n = rest_.rows();
  const Matrix& delta = delta_;
  std::vector<Eigen::Triplet<double>> e;
  for (Eigen::Index i = 0; i < n; ++i) {
    std::vector<int> ring{int(i)};
    for (const auto& [j, w] : neighbors_[i]) ring.push_back(j);
    const int k = int(ring.size());
    Eigen::MatrixXd a(3 * k, 7);
    for (int r = 0; r < k; ++r) {
      const double x = rest_(ring[r], 0), y = rest_(ring[r], 1), z = rest_(ring[r], 2);
      a.row(3 * r) << x, 0, z, -y, 1, 0, 0;
      a.row(3 * r + 1) << y, -z, 0, x, 0, 1, 0;
      a.row(3 * r + 2) << z, y, -x, 0, 0, 0, 1;
    }
    // (s, h, t) = (A^T A)^-1 A^T b; a lone vertex (k = 1) fits nothing, so it keeps delta fixed.
    const Eigen::MatrixXd fit = a.completeOrthogonalDecomposition().pseudoInverse();
    const double dx = delta(i, 0), dy = delta(i, 1), dz = delta(i, 2);
    Eigen::Matrix<double, 3, 4> d;
    d << dx, 0, dz, -dy,  //
        dy, -dz, 0, dx,   //
        dz, dy, -dx, 0;
    const Eigen::MatrixXd c = d * fit.topRows(4);  // T_i delta_i = C_i b_i, b_i the ring's coordinates
    for (int row = 0; row < 3; ++row) {
      for (int r = 0; r < k; ++r)
        for (int col = 0; col < 3; ++col)
          if (c(row, 3 * r + col) != 0.0) e.emplace_back(int(3 * i + row), 3 * ring[r] + col, c(row, 3 * r + col));
      // - (L V')_i
      for (SparseMatrix::InnerIterator it(laplacian_, i); it; ++it)
        e.emplace_back(int(3 * i + row), int(3 * it.row() + row), -it.value());
    }
  }
  SparseMatrix m(3 * n, 3 * n);
  m.setFromTriplets(e.begin(), e.end());
  m.makeCompressed();
  return m;
}

SurfaceDeformer::Matrix SurfaceDeformer::deform_rotation_invariant(const Matrix& fixed, const Matrix& pulls) const {
  Matrix x = with_fixed(fixed);
  const Displacement d = displacement(fixed, pulls);
  if (split_.free().empty() || d.at_rest) return x;
  // 1. The linearised implicit transforms; a loosely held mesh is pulled towards the naive solution.
  const Eigen::MatrixXd naive = implicit_system_.ridge() > 0
                                    ? interleave(Matrix(laplacian_system_.solve_free({}, d.moved, d.pulled)))
                                    : Eigen::MatrixXd();
  const Eigen::MatrixXd df = implicit_system_.solve_free({}, interleave(d.moved), interleave(d.pulled), naive);
  for (std::size_t i = 0; i < split_.free().size(); ++i)
    x.row(split_.free()[i]) += df.block<3, 1>(Eigen::Index(3 * i), 0).transpose();
  // 2. Their linearisation lets each T_i scale, more the more it turns. Keep only the rotation
  // each one-ring underwent (its polar factor, as ARAP's local step) and solve the least
  // squares of sec. 3 for the differential coordinates so rotated: R_i delta_i, unscaled.
  std::vector<Mat3> rotations(rest_.rows());
  Matrix turned(rest_.rows(), 3);
  for (int pass = 0; pass < settings_.iterations; ++pass) {
    fit_rotations(x, rotations);
    for (Eigen::Index i = 0; i < rest_.rows(); ++i) turned.row(i) = (rotations[i] * delta_.row(i).transpose()).transpose();
    x = with_fixed(fixed);
    add_to_free(x, laplacian_system_.solve_free(Eigen::MatrixXd(turned - delta_), d.moved, d.pulled));
  }
  return x;
}

}  // namespace deformkit
