#include "deformkit/surface/surface_deformer.hpp"

#include "deformkit/numerics/best_rotation.hpp"
#include "deformkit/core/deformer.hpp"
#include "core/parallel.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <sstream>
#include <stdexcept>

namespace deformkit {

namespace {

std::vector<int> checked_indices(std::vector<int> idx, std::size_t n, const char* name) {
  for (int v : idx)
    if (v < 0 || std::size_t(v) >= n)
      throw std::invalid_argument(std::string(name) + ": index " + std::to_string(v) + " is outside 0.." +
                                  std::to_string(n - 1));
  std::vector<int> sorted = idx;
  std::sort(sorted.begin(), sorted.end());
  const auto dup = std::adjacent_find(sorted.begin(), sorted.end());
  if (dup != sorted.end()) throw std::invalid_argument(std::string(name) + ": index " + std::to_string(*dup) + " is repeated");
  return idx;
}

// Negative cotangent weights (an edge opposite two obtuse angles) make the ARAP global step
// indefinite and its energy non-monotone: they are raised to a small positive floor.
SparseMatrix with_positive_weights(const SparseMatrix& l) {
  double sum = 0;
  int count = 0;
  for (int k = 0; k < l.outerSize(); ++k)
    for (SparseMatrix::InnerIterator it(l, k); it; ++it)
      if (it.row() != it.col() && -it.value() > 0) sum += -it.value(), ++count;
  const double floor = count ? 1e-3 * sum / count : 1e-3;
  std::vector<Eigen::Triplet<double>> e;
  for (int k = 0; k < l.outerSize(); ++k)
    for (SparseMatrix::InnerIterator it(l, k); it; ++it) {
      if (it.row() == it.col()) continue;
      const double w = std::max(-it.value(), floor);
      e.emplace_back(it.row(), it.col(), -w);
      e.emplace_back(it.row(), it.row(), w);
    }
  SparseMatrix out(l.rows(), l.cols());
  out.setFromTriplets(e.begin(), e.end());
  out.makeCompressed();
  return out;
}

void require_meaningful_constraint_weight(const std::optional<double>& w) {
  if (!w || (*w >= kMinConstraintWeight && *w <= kMaxConstraintWeight)) return;
  std::ostringstream msg;
  msg << "constraint_weight: expected None (hard constraints) or a number in [" << kMinConstraintWeight << ", "
      << kMaxConstraintWeight << "], got " << *w;
  throw std::invalid_argument(msg.str());
}

double soft_weight_squared(const SurfaceSettings& s) { return s.constraint_weight ? *s.constraint_weight * *s.constraint_weight : 0.0; }

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

SurfaceDeformer::SurfaceDeformer(TriangleMesh mesh, std::vector<int> anchors, std::vector<int> handles,
                                 const std::optional<std::vector<int>>& roi, SurfaceSettings settings)
    : mesh_(std::move(mesh)), settings_(settings) {
  const std::size_t n = mesh_.vertex_count();
  if (settings.iterations < 1 || settings.iterations > 10000)
    throw std::invalid_argument("iterations: must be 1..10000");
  if (!(settings.tolerance >= 0.0) || !std::isfinite(settings.tolerance))
    throw std::invalid_argument("tolerance: must be a finite number >= 0");
  require_meaningful_constraint_weight(settings.constraint_weight);
  const bool soft = settings.constraint_weight.has_value();
  anchors = checked_indices(std::move(anchors), n, "anchors");
  handles_ = checked_indices(std::move(handles), n, "handles");
  if (anchors.empty() && handles_.empty())
    throw std::invalid_argument("anchors: no anchors and no handles, so nothing holds the mesh in place");
  // held: 1 exactly (outside roi, or a hard constraint), 2 softly (a soft constraint inside roi).
  std::vector<char> held(n, 0), is_handle(n, 0);
  for (int v : handles_) is_handle[v] = 1;
  for (int v : anchors)
    if (is_handle[v]) throw std::invalid_argument("anchors: vertex " + std::to_string(v) + " is also a handle");
  if (roi) {
    std::vector<char> inside(n, 0);
    for (int v : checked_indices(*roi, n, "roi")) inside[v] = 1;
    for (std::size_t v = 0; v < n; ++v)
      if (!inside[v]) held[v] = 1;  // outside the region of interest: held at rest
  }
  std::vector<int> constraint_handle(n, -2);  // -2 none, -1 anchor, h handle
  for (int v : anchors) constraint_handle[v] = -1;
  for (std::size_t h = 0; h < handles_.size(); ++h) constraint_handle[handles_[h]] = int(h);
  for (std::size_t v = 0; v < n; ++v)
    if (constraint_handle[v] != -2 && (!soft || (held[v] && constraint_handle[v] == -1))) held[v] = 1;
    else if (constraint_handle[v] != -2) held[v] = 2;  // a soft handle goes to its target even outside roi
  // A component that nothing holds would make the system singular: it stays where it is.
  int components = 0;
  const std::vector<int> component = connected_components(mesh_, &components);
  std::vector<char> component_held(components, 0);
  std::vector<int> size(components, 0);
  for (std::size_t v = 0; v < n; ++v) {
    component_held[component[v]] |= held[v] != 0;
    ++size[component[v]];
  }
  for (int c = 0; c < components; ++c)
    if (!component_held[c])
      warnings_.push_back("component " + std::to_string(c) + " (" + std::to_string(size[c]) +
                          " vertices) has no anchor or handle; it is left where it is");
  free_index_.assign(n, -1);
  fixed_index_.assign(n, -1);
  for (std::size_t v = 0; v < n; ++v) {
    if (held[v] == 1 || !component_held[component[v]]) {
      fixed_index_[v] = int(fixed_.size());
      fixed_.push_back(int(v));
    } else {
      free_index_[v] = int(free_.size());
      if (held[v] == 2) soft_.push_back(free_index_[v]), soft_handle_.push_back(constraint_handle[v]);
      free_.push_back(int(v));
    }
  }
  rest_ = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(mesh_.points.data(), Eigen::Index(n), 3);
  laplacian_ = with_positive_weights(settings.uniform_weights ? uniform_laplacian(mesh_) : cotangent_laplacian(mesh_));
  neighbors_.assign(n, {});
  for (int k = 0; k < laplacian_.outerSize(); ++k)
    for (SparseMatrix::InnerIterator it(laplacian_, k); it; ++it)
      if (it.row() != it.col()) neighbors_[k].emplace_back(int(it.row()), -it.value());
  const double w2 = soft_weight_squared(settings);

  delta_ = laplacian_ * rest_;
  if (settings.method == SurfaceMethod::RotationInvariant) factorize_rotation_invariant(component, components, held);
  // Split the columns into free and fixed vertices; ARAP keeps only the free rows (Dirichlet).
  const bool arap = settings.method == SurfaceMethod::Arap;
  std::vector<Eigen::Triplet<double>> f, c;
  for (int k = 0; k < laplacian_.outerSize(); ++k)
    for (SparseMatrix::InnerIterator it(laplacian_, k); it; ++it) {
      const int row = arap ? free_index_[it.row()] : int(it.row());
      if (row < 0) continue;
      if (free_index_[k] >= 0) f.emplace_back(row, free_index_[k], it.value());
      else c.emplace_back(row, fixed_index_[k], it.value());
    }
  const Eigen::Index rows = arap ? Eigen::Index(free_.size()) : Eigen::Index(n);
  free_part_.resize(rows, Eigen::Index(free_.size()));
  free_part_.setFromTriplets(f.begin(), f.end());
  fixed_part_.resize(rows, Eigen::Index(fixed_.size()));
  fixed_part_.setFromTriplets(c.begin(), c.end());
  if (free_.empty()) return;
  // ARAP: L_ff, the global step (Sorkine and Alexa 2007, eq. 9). Laplacian: the normal equations of
  // min ||L x' - delta||^2 over the free vertices (Sorkine et al. 2004, eq. 5), solved for the
  // displacement. Soft constraints add w^2 on their diagonal.
  SparseMatrix system = arap ? free_part_ : SparseMatrix(SparseMatrix(free_part_.transpose()) * free_part_);
  for (int s : soft_) system.coeffRef(s, s) += w2;
  factorize(system, CholeskyKind::Supernodal);
}

// Sorkine et al. 2004, sec. 4: the 3n x 3n least-squares system of the implicit transforms, over
// the free coordinates (the first of the rotation-invariant method's two solves).
void SurfaceDeformer::factorize_rotation_invariant(const std::vector<int>& component, int components,
                                                   const std::vector<char>& held) {
  // Unknowns are the 3n coordinates (x0, y0, z0, x1, ...): the implicit transforms couple them.
  const SparseMatrix m = implicit_transform_system();
  std::vector<Eigen::Triplet<double>> f, c;
  for (int k = 0; k < m.outerSize(); ++k)
    for (SparseMatrix::InnerIterator it(m, k); it; ++it) {
      const int v = k / 3, a = k % 3;
      if (free_index_[v] >= 0) f.emplace_back(int(it.row()), 3 * free_index_[v] + a, it.value());
      else c.emplace_back(int(it.row()), 3 * fixed_index_[v] + a, it.value());
    }
  ri_free_.resize(m.rows(), Eigen::Index(3 * free_.size()));
  ri_free_.setFromTriplets(f.begin(), f.end());
  ri_fixed_.resize(m.rows(), Eigen::Index(3 * fixed_.size()));
  ri_fixed_.setFromTriplets(c.begin(), c.end());
  if (free_.empty()) return;
  SparseMatrix normal = SparseMatrix(ri_free_.transpose()) * ri_free_;
  // With fewer than three non-collinear held vertices in a component, the linearised rotations
  // about them cost nothing: the system is singular (whether a factorisation notices depends on
  // rounding). A Tikhonov term ridge ||d - d_laplacian||^2, 1e-6 of the mean diagonal (before the
  // soft constraints, whose weight must not change it), then picks among the minimisers the one
  // nearest the naive Laplacian solution: a translated handle translates the mesh.
  if (loosely_held(component, components, held)) {
    ridge_ = 1e-6 * normal.diagonal().sum() / double(normal.rows());
    for (Eigen::Index k = 0; k < normal.rows(); ++k) normal.coeffRef(k, k) += ridge_;
    warnings_.push_back("rotation_invariant: a component is held by fewer than three non-collinear vertices, "
                        "so it may turn freely about them; the solution nearest the 'laplacian' method's is used");
  }
  const double w2 = soft_weight_squared(settings_);
  for (int s : soft_)
    for (int a = 0; a < 3; ++a) normal.coeffRef(3 * s + a, 3 * s + a) += w2;
  if (!ri_solver_.factorize(normal, CholeskyKind::Supernodal))
    throw std::invalid_argument("faces: the mesh's rotation-invariant system could not be factorised (degenerate geometry)");
}

void SurfaceDeformer::factorize(const SparseMatrix& system, CholeskyKind kind) {
  if (!solver_.factorize(system, kind))
    throw std::invalid_argument("faces: the mesh's Laplacian system could not be factorised (degenerate geometry)");
}

// The positions the soft constraints pull towards: the handle's target, an anchor's rest.
SurfaceDeformer::Matrix SurfaceDeformer::soft_targets(const double* targets) const {
  Matrix c(Eigen::Index(soft_.size()), 3);
  for (std::size_t k = 0; k < soft_.size(); ++k) {
    const int h = soft_handle_[k];
    c.row(Eigen::Index(k)) = h < 0 ? Matrix(rest_.row(free_[soft_[k]])) :
        Matrix(Eigen::RowVector3d(targets[3 * h], targets[3 * h + 1], targets[3 * h + 2]));
  }
  return c;
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

SurfaceDeformer::Matrix SurfaceDeformer::solve(const Matrix& rhs_free, const Matrix& fixed) const {
  Matrix x(rest_.rows(), 3);
  for (std::size_t i = 0; i < fixed_.size(); ++i) x.row(fixed_[i]) = fixed.row(Eigen::Index(i));
  if (free_.empty()) return x;
  const Matrix xf = solver_.solve(rhs_free);
  for (std::size_t i = 0; i < free_.size(); ++i) x.row(free_[i]) = xf.row(Eigen::Index(i));
  return x;
}

// Local step: R_i maximising tr(R_i S_i), S_i = sum_j w_ij e_ij e'_ij^T.
void SurfaceDeformer::fit_rotations(const Matrix& x, std::vector<Mat3>& rotations) const {
  parallel_blocks(rest_.rows(), [&](std::size_t begin, std::size_t end) {
    constexpr std::size_t kChunk = 512;  // S and R of a chunk, component-major for the SIMD polar step
    std::vector<double> s(9 * kChunk), r(9 * kChunk);
    for (std::size_t first = begin; first < end; first += kChunk) {
      const std::size_t count = std::min(kChunk, end - first);
      for (std::size_t i = first; i < first + count; ++i) {
        Mat3 si = Mat3::Zero();
        const Vec3 xi = x.row(i).transpose(), pi = rest_.row(i).transpose();
        for (const auto& [j, w] : neighbors_[i])
          si.noalias() += (w * (pi - rest_.row(j).transpose())) * (xi - x.row(j).transpose()).transpose();
        for (int k = 0; k < 9; ++k) s[std::size_t(k) * count + (i - first)] = si(k / 3, k % 3);
      }
      best_rotations(s.data(), r.data(), count);
      for (std::size_t i = 0; i < count; ++i)
        for (int k = 0; k < 9; ++k) rotations[first + i](k / 3, k % 3) = r[std::size_t(k) * count + i];
    }
  });
}

// b_i = sum_j w_ij / 2 (R_i + R_j)(p_i - p_j), on the free rows (Sorkine and Alexa 2007, eq. 8).
SurfaceDeformer::Matrix SurfaceDeformer::arap_rhs(const std::vector<Mat3>& rotations) const {
  Matrix b(Eigen::Index(free_.size()), 3);
  parallel_blocks(free_.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t f = begin; f < end; ++f) {
      const int i = free_[f];
      Vec3 acc = Vec3::Zero();
      for (const auto& [j, w] : neighbors_[i])
        acc += 0.5 * w * (rotations[i] + rotations[j]) * (rest_.row(i) - rest_.row(j)).transpose();
      b.row(Eigen::Index(f)) = acc.transpose();
    }
  });
  return b;
}

double SurfaceDeformer::arap_energy(const Matrix& x, const std::vector<Mat3>& rotations) const {
  double total = 0;
  std::mutex add;
  parallel_blocks(rest_.rows(), [&](std::size_t begin, std::size_t end) {
    double e = 0;
    for (std::size_t i = begin; i < end; ++i)
      for (const auto& [j, w] : neighbors_[i])
        e += w * ((x.row(i) - x.row(j)).transpose() - rotations[i] * (rest_.row(i) - rest_.row(j)).transpose())
                     .squaredNorm();
    const std::lock_guard<std::mutex> lock(add);
    total += e;
  });
  return total;
}

std::vector<double> SurfaceDeformer::deform(const double* targets) {
  require_finite_rows(targets, handles_.size(), "handle_targets");
  const std::lock_guard<std::mutex> lock(deforming_);
  Matrix fixed(Eigen::Index(fixed_.size()), 3);
  for (std::size_t i = 0; i < fixed_.size(); ++i) fixed.row(Eigen::Index(i)) = rest_.row(fixed_[i]);
  for (std::size_t h = 0; h < handles_.size(); ++h)
    if (fixed_index_[handles_[h]] >= 0)
      fixed.row(fixed_index_[handles_[h]]) = Eigen::RowVector3d(targets[3 * h], targets[3 * h + 1], targets[3 * h + 2]);
  const Matrix pulls = soft_targets(targets);
  const double w2 = soft_weight_squared(settings_);
  energy_.clear();
  Matrix x = rest_;
  for (std::size_t i = 0; i < fixed_.size(); ++i) x.row(fixed_[i]) = fixed.row(Eigen::Index(i));
  // The linear methods solve for the displacement from rest (M rest = 0 exactly in exact
  // arithmetic), so that handles at rest give the rest mesh to the last bit on any mesh, however
  // ill-conditioned its clamped weights make the system.
  Matrix moved(fixed.rows(), 3), pulled(pulls.rows(), 3);
  for (std::size_t i = 0; i < fixed_.size(); ++i) moved.row(Eigen::Index(i)) = fixed.row(Eigen::Index(i)) - rest_.row(fixed_[i]);
  for (std::size_t k = 0; k < soft_.size(); ++k) pulled.row(Eigen::Index(k)) = pulls.row(Eigen::Index(k)) - rest_.row(free_[soft_[k]]);
  const bool at_rest = moved.isZero(0.0) && pulled.isZero(0.0);
  if (free_.empty()) {
  } else if (settings_.method == SurfaceMethod::RotationInvariant) {
    if (!at_rest) {
      // 1. The linearised implicit transforms (Sorkine et al. 2004, sec. 4).
      Eigen::VectorXd dc(3 * moved.rows());  // interleaved x0, y0, z0, x1, ...
      for (Eigen::Index i = 0; i < moved.rows(); ++i) dc.segment<3>(3 * i) = moved.row(i).transpose();
      Eigen::VectorXd rhs = -(ri_free_.transpose() * (ri_fixed_ * dc));
      for (std::size_t k = 0; k < soft_.size(); ++k) rhs.segment<3>(3 * soft_[k]) += w2 * pulled.row(Eigen::Index(k)).transpose();
      if (ridge_ > 0) {  // towards the naive solution (see factorize_rotation_invariant)
        Matrix naive_rhs = -(free_part_.transpose() * (fixed_part_ * moved));
        for (std::size_t k = 0; k < soft_.size(); ++k) naive_rhs.row(soft_[k]) += w2 * pulled.row(Eigen::Index(k));
        const Matrix naive = solver_.solve(naive_rhs);
        for (Eigen::Index i = 0; i < naive.rows(); ++i) rhs.segment<3>(3 * i) += ridge_ * naive.row(i).transpose();
      }
      const Eigen::VectorXd df = ri_solver_.solve(rhs);
      for (std::size_t i = 0; i < free_.size(); ++i) x.row(free_[i]) += df.segment<3>(Eigen::Index(3 * i)).transpose();
      // 2. Their linearisation lets each T_i scale, more the more it turns. Keep only the rotation
      // each one-ring underwent (its polar factor, as ARAP's local step) and solve the least
      // squares of sec. 3 for the differential coordinates so rotated: R_i delta_i, unscaled.
      std::vector<Mat3> rotations(rest_.rows());
      Matrix turned(rest_.rows(), 3);
      for (int pass = 0; pass < settings_.iterations; ++pass) {
        fit_rotations(x, rotations);
        for (Eigen::Index i = 0; i < rest_.rows(); ++i) turned.row(i) = (rotations[i] * delta_.row(i).transpose()).transpose();
        x = rest_;
        for (std::size_t i = 0; i < fixed_.size(); ++i) x.row(fixed_[i]) = fixed.row(Eigen::Index(i));
        Matrix rhs2 = free_part_.transpose() * Matrix(turned - delta_ - fixed_part_ * moved);
        for (std::size_t k = 0; k < soft_.size(); ++k) rhs2.row(soft_[k]) += w2 * pulled.row(Eigen::Index(k));
        const Matrix d = solver_.solve(rhs2);
        for (std::size_t i = 0; i < free_.size(); ++i) x.row(free_[i]) += d.row(Eigen::Index(i));
      }
    }
  } else if (settings_.method == SurfaceMethod::Laplacian) {
    if (!at_rest) {
      Matrix rhs = -(free_part_.transpose() * (fixed_part_ * moved));
      for (std::size_t k = 0; k < soft_.size(); ++k) rhs.row(soft_[k]) += w2 * pulled.row(Eigen::Index(k));
      const Matrix df = solver_.solve(rhs);
      for (std::size_t i = 0; i < free_.size(); ++i) x.row(free_[i]) += df.row(Eigen::Index(i));
    }
  } else {
    std::vector<Mat3> rotations(rest_.rows(), Mat3::Identity());
    Matrix held = fixed_part_ * fixed;
    for (std::size_t k = 0; k < soft_.size(); ++k) held.row(soft_[k]) -= w2 * pulls.row(Eigen::Index(k));
    x = solve(arap_rhs(rotations) - held, fixed);  // the first global step, from R = I
    for (int it = 0; it < settings_.iterations; ++it) {
      fit_rotations(x, rotations);
      x = solve(arap_rhs(rotations) - held, fixed);
      double e = arap_energy(x, rotations);
      for (std::size_t k = 0; k < soft_.size(); ++k)
        e += 2 * w2 * (x.row(free_[soft_[k]]) - pulls.row(Eigen::Index(k))).squaredNorm();
      energy_.push_back(e);
      const std::size_t k = energy_.size();
      if (settings_.tolerance > 0 && k > 1 && energy_[k - 2] - energy_[k - 1] <= settings_.tolerance * energy_[k - 2])
        break;
    }
  }
  if (!x.allFinite())
    throw std::invalid_argument("handle_targets: the solve overflowed (targets too far from the mesh)");
  std::vector<double> out(3 * rest_.rows());
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(out.data(), rest_.rows(), 3) = x;
  return out;
}

}  // namespace deformkit
