// The rotation-invariant Laplacian editing of Sorkine et al. 2004, sec. 4: the linearised implicit
// transforms as one constrained least-squares system over the 3n coordinates, then passes that
// rotate the differential coordinates without the linearisation's scale.
#include "deformkit/surface/surface_deformer.hpp"

#include "core/parallel.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>

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

namespace {

// The rows of the fit of T_i = s I + [h]x + t to the one-ring (Sorkine et al. 2004, sec. 4) for
// points p_r: x, 0, z, -y (s, h) and the unit vectors (t); a ring's 3k rows by 7.
Eigen::MatrixXd ring_rows(const Eigen::Matrix<double, Eigen::Dynamic, 3>& rest, const std::vector<int>& ring) {
  Eigen::MatrixXd a(3 * Eigen::Index(ring.size()), 7);
  for (std::size_t r = 0; r < ring.size(); ++r) {
    const double x = rest(ring[r], 0), y = rest(ring[r], 1), z = rest(ring[r], 2);
    const auto q = Eigen::Index(3 * r);
    a.row(q) << x, 0, z, -y, 1, 0, 0;
    a.row(q + 1) << y, -z, 0, x, 0, 1, 0;
    a.row(q + 2) << z, y, -x, 0, 0, 0, 1;
  }
  return a;
}

// (s, h) as a linear map of the ring's new coordinates (4 x 3k): the first four rows of the
// least-squares fit's pseudo-inverse. The fit of t absorbs any shift of the coordinates, so with
// the ring centred on its mean (and scaled to unit size) the (s, h) columns are orthogonal to the
// t ones and (s, h) = (B^T B)^-1 B^T b with B the centred (s, h) columns: a 4 x 4 solve, as exact as
// the 7-column pseudo-inverse and ~30x cheaper. A degenerate ring (all on a line, or one point)
// takes the pseudo-inverse of the 7 columns as it is.
Eigen::Matrix<double, 4, Eigen::Dynamic> similarity_fit(const Eigen::Matrix<double, Eigen::Dynamic, 3>& rest,
                                                       const std::vector<int>& ring) {
  const auto k = Eigen::Index(ring.size());
  Eigen::RowVector3d mean = Eigen::RowVector3d::Zero();
  for (int v : ring) mean += rest.row(v);
  mean /= double(k);
  double size = 0;
  for (int v : ring) size = std::max(size, (rest.row(v) - mean).cwiseAbs().maxCoeff());
  if (size > 0) {
    Eigen::Matrix<double, Eigen::Dynamic, 4> b(3 * k, 4);
    for (Eigen::Index r = 0; r < k; ++r) {
      const Eigen::RowVector3d q = (rest.row(ring[std::size_t(r)]) - mean) / size;
      b.row(3 * r) << q[0], 0, q[2], -q[1];
      b.row(3 * r + 1) << q[1], -q[2], 0, q[0];
      b.row(3 * r + 2) << q[2], q[1], -q[0], 0;
    }
    const Eigen::Matrix4d gram = b.transpose() * b;
    const Eigen::LDLT<Eigen::Matrix4d> ldlt(gram);
    const Eigen::Vector4d d = ldlt.vectorD().cwiseAbs();
    if (ldlt.info() == Eigen::Success && d.minCoeff() > 1e-10 * d.maxCoeff())
      return ldlt.solve(Eigen::Matrix<double, 4, Eigen::Dynamic>(b.transpose())) / size;
  }
  return ring_rows(rest, ring).completeOrthogonalDecomposition().pseudoInverse().topRows(4);
}

}  // namespace

// Sorkine et al. 2004, sec. 4: each vertex's transform T_i = s I + [h]x + t, fitted by least squares
// to its one-ring, is linear in the unknown positions; the rows T_i(V') delta_i - L(V')_i then
// ask the differential coordinates to follow their own (linearised) rotation and scale. Built row
// by row (a vertex's three rows at once, on the pool's threads), then turned into columns.
SparseMatrix SurfaceDeformer::implicit_transform_system() const {
  const Eigen::Index n = rest_.rows();
  using RowMajor = Eigen::SparseMatrix<double, Eigen::RowMajor>;
  // Per vertex: its ring ascending, the 3 x 3k block of T_i delta_i minus the Laplacian's rows.
  std::vector<std::vector<int>> rings(static_cast<std::size_t>(n));
  std::vector<Eigen::MatrixXd> blocks(static_cast<std::size_t>(n));
  parallel_blocks(std::size_t(n), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      std::vector<int>& ring = rings[i];
      ring.assign(1, int(i));
      for (const auto& [j, w] : neighbors_[i]) ring.push_back(j);
      std::sort(ring.begin(), ring.end());
      const double dx = delta_(Eigen::Index(i), 0), dy = delta_(Eigen::Index(i), 1), dz = delta_(Eigen::Index(i), 2);
      Eigen::Matrix<double, 3, 4> d;
      d << dx, 0, dz, -dy,  //
          dy, -dz, 0, dx,   //
          dz, dy, -dx, 0;
      // A lone vertex (k = 1) has delta = 0: it keeps delta fixed.
      blocks[i] = d * similarity_fit(rest_, ring);  // T_i delta_i = C_i b_i, b_i the ring's coordinates
    }
  });
  std::vector<RowMajor::StorageIndex> outer(std::size_t(3 * n) + 1, 0), inner;
  std::vector<double> value;
  for (Eigen::Index i = 0; i < n; ++i) {
    const std::vector<int>& ring = rings[std::size_t(i)];
    const Eigen::MatrixXd& c = blocks[std::size_t(i)];
    SparseMatrix::InnerIterator l(laplacian_, i);  // column i = row i, ascending as the ring
    std::vector<double> li(ring.size(), 0.0);
    for (std::size_t r = 0; r < ring.size(); ++r) {
      while (l && l.row() < ring[r]) ++l;
      if (l && l.row() == ring[r]) li[r] = l.value();
    }
    for (int row = 0; row < 3; ++row) {
      for (std::size_t r = 0; r < ring.size(); ++r)
        for (int col = 0; col < 3; ++col) {
          const double v = c(row, Eigen::Index(3 * r) + col);
          // - (L V')_i on the row's own coordinate
          if (col == row) inner.push_back(3 * ring[r] + col), value.push_back(v + -li[r]);
          else if (v != 0.0) inner.push_back(3 * ring[r] + col), value.push_back(v);
        }
      outer[std::size_t(3 * i + row) + 1] = RowMajor::StorageIndex(inner.size());
    }
  }
  RowMajor m(3 * n, 3 * n);
  m.resizeNonZeros(Eigen::Index(inner.size()));
  std::copy(outer.begin(), outer.end(), m.outerIndexPtr());
  std::copy(inner.begin(), inner.end(), m.innerIndexPtr());
  std::copy(value.begin(), value.end(), m.valuePtr());
  return SparseMatrix(m);
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
