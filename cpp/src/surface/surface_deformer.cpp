#include "deformkit/surface/surface_deformer.hpp"

#include "deformkit/core/validation.hpp"
#include "numerics/fill_ordering.hpp"
#include "numerics/normal_equations.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
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
SparseMatrix with_positive_weights(SparseMatrix l) {
  double sum = 0;
  int count = 0;
  for (int k = 0; k < l.outerSize(); ++k)
    for (SparseMatrix::InnerIterator it(l, k); it; ++it)
      if (it.row() != it.col() && -it.value() > 0) sum += -it.value(), ++count;
  const double floor = count ? 1e-3 * sum / count : 1e-3;
  // In place: the pattern stays, each column's diagonal is the sum of its raised weights.
  for (int k = 0; k < l.outerSize(); ++k) {
    double diagonal = 0, *at_diagonal = nullptr;
    for (SparseMatrix::InnerIterator it(l, k); it; ++it) {
      if (it.row() == it.col()) {
        at_diagonal = &it.valueRef();
        continue;
      }
      const double w = std::max(-it.value(), floor);
      it.valueRef() = -w;
      diagonal += w;
    }
    if (at_diagonal) *at_diagonal = diagonal;
  }
  return l;
}

void require_meaningful_constraint_weight(const std::optional<double>& w) {
  if (!w || (*w >= kMinConstraintWeight && *w <= kMaxConstraintWeight)) return;
  std::ostringstream msg;
  msg << "constraint_weight: expected None (hard constraints) or a number in [" << kMinConstraintWeight << ", "
      << kMaxConstraintWeight << "], got " << *w;
  throw std::invalid_argument(msg.str());
}

double soft_weight_squared(const SurfaceSettings& s) { return s.constraint_weight ? *s.constraint_weight * *s.constraint_weight : 0.0; }

void check_settings(const SurfaceSettings& s) {
  if (s.iterations < 1 || s.iterations > 10000) throw std::invalid_argument("iterations: must be 1..10000");
  if (s.anderson < 0 || s.anderson > 50) throw std::invalid_argument("anderson: must be 0..50");
  if (!(s.tolerance >= 0.0) || !std::isfinite(s.tolerance))
    throw std::invalid_argument("tolerance: must be a finite number >= 0");
  require_meaningful_constraint_weight(s.constraint_weight);
}

// How each vertex is held. held: 0 free, 1 exactly (outside roi, or a hard constraint), 2 softly
// (a soft constraint); constraint: -2 none, -1 an anchor, h handle h.
struct Holds {
  std::vector<char> held;
  std::vector<int> constraint;
};

Holds hold_vertices(std::size_t n, const std::vector<int>& anchors, const std::vector<int>& handles,
                    const std::optional<std::vector<int>>& roi, bool soft) {
  Holds h{std::vector<char>(n, 0), std::vector<int>(n, -2)};
  std::vector<char> is_handle(n, 0);
  for (int v : handles) is_handle[v] = 1;
  for (int v : anchors)
    if (is_handle[v]) throw std::invalid_argument("anchors: vertex " + std::to_string(v) + " is also a handle");
  if (roi) {
    std::vector<char> inside(n, 0);
    for (int v : checked_indices(*roi, n, "roi")) inside[v] = 1;
    for (std::size_t v = 0; v < n; ++v)
      if (!inside[v]) h.held[v] = 1;  // outside the region of interest: held at rest
  }
  for (int v : anchors) h.constraint[v] = -1;
  for (std::size_t k = 0; k < handles.size(); ++k) h.constraint[handles[k]] = int(k);
  for (std::size_t v = 0; v < n; ++v)
    if (h.constraint[v] != -2 && (!soft || (h.held[v] && h.constraint[v] == -1))) h.held[v] = 1;
    else if (h.constraint[v] != -2) h.held[v] = 2;  // a soft handle goes to its target even outside roi
  return h;
}

// The vertices held exactly: those held so, and every vertex of a component that nothing holds
// (it would make the system singular), which stays where it is with a warning.
std::vector<char> fixed_vertices(const std::vector<char>& held, const std::vector<int>& component, int components,
                                 std::vector<std::string>& warnings) {
  std::vector<char> component_held(components, 0);
  std::vector<int> size(components, 0);
  for (std::size_t v = 0; v < held.size(); ++v) {
    component_held[component[v]] |= held[v] != 0;
    ++size[component[v]];
  }
  for (int c = 0; c < components; ++c)
    if (!component_held[c])
      warnings.push_back("component " + std::to_string(c) + " (" + std::to_string(size[c]) +
                         " vertices) has no anchor or handle; it is left where it is");
  std::vector<char> fixed(held.size(), 0);
  for (std::size_t v = 0; v < held.size(); ++v) fixed[v] = held[v] == 1 || !component_held[component[v]];
  return fixed;
}

std::vector<int> identity_index(std::size_t n) {
  std::vector<int> index(n);
  for (std::size_t i = 0; i < n; ++i) index[i] = int(i);
  return index;
}

// The same soft constraints on each of a vertex's `width` interleaved coordinates.
SoftConstraints interleaved(const SoftConstraints& soft, int width) {
  SoftConstraints out;
  for (std::size_t k = 0; k < soft.unknowns.size(); ++k)
    for (int a = 0; a < width; ++a) {
      out.unknowns.push_back(width * soft.unknowns[k] + a);
      out.weights.push_back(soft.weights[k]);
    }
  return out;
}

}  // namespace

SurfaceDeformer::SurfaceDeformer(PolygonMesh mesh, std::vector<int> anchors, std::vector<int> handles,
                                 const std::optional<std::vector<int>>& roi, SurfaceSettings settings)
    : mesh_(std::move(mesh).triangulate()), settings_(settings) {
  StageClock clock(bind_stages_);
  const std::size_t n = mesh_.vertex_count();
  check_settings(settings);
  anchors = checked_indices(std::move(anchors), n, "anchors");
  handles_ = checked_indices(std::move(handles), n, "handles");
  if (anchors.empty() && handles_.empty())
    throw std::invalid_argument("anchors: no anchors and no handles, so nothing holds the mesh in place");
  const Holds holds = hold_vertices(n, anchors, handles_, roi, settings.constraint_weight.has_value());
  int components = 0;
  const std::vector<int> component = connected_components(mesh_, &components);
  split_ = UnknownSplit(fixed_vertices(holds.held, component, components, warnings_));
  clock.mark("checks, components, free / fixed split");
  SoftConstraints soft;
  for (std::size_t v = 0; v < n; ++v)
    if (!split_.is_fixed(int(v)) && holds.held[v] == 2) {
      soft.unknowns.push_back(int(v));
      soft.weights.push_back(soft_weight_squared(settings));
      soft_handle_.push_back(holds.constraint[v]);
    }
  rest_ = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(mesh_.points().data(), Eigen::Index(n), 3);
  length_unit_ = length_unit(rest_);
  laplacian_ = with_positive_weights(settings.uniform_weights ? uniform_laplacian(mesh_) : cotangent_laplacian(mesh_));
  clock.mark("Laplacian assembly");
  neighbors_.assign(n, {});
  for (int k = 0; k < laplacian_.outerSize(); ++k)
    for (SparseMatrix::InnerIterator it(laplacian_, k); it; ++it)
      if (it.row() != it.col()) neighbors_[k].emplace_back(int(it.row()), -it.value());
  delta_ = laplacian_ * rest_;
  clock.mark("neighbour lists, delta");
  // The fill-reducing ordering of all vertices for the system's pattern (L's, or L^T L's, which the
  // rotation-invariant 3n system has in 3 x 3 blocks), remembered for this connectivity and
  // restricted to the free vertices by each system.
  const bool squared = settings.method != SurfaceMethod::Arap;
  bool remembered = false;
  const auto ordering = remembered_ordering(pattern_digest(laplacian_) ^ (squared ? 0x5eedull : 0x1ull), [&] {
    return amd_ordering(squared ? normal_equations(laplacian_) : lower_triangle(laplacian_));
  }, &remembered);
  clock.mark(remembered ? "ordering (remembered for this connectivity)" : "ordering (AMD on all vertices)");
  if (settings.method == SurfaceMethod::RotationInvariant) {
    // With fewer than three non-collinear held vertices in a component, the linearised rotations
    // about them cost nothing: the system is singular (whether a factorisation notices depends on
    // rounding). A ridge of 1e-6 of the mean diagonal then picks among the minimisers the one
    // nearest the naive Laplacian solution: a translated handle translates the mesh.
    const bool loose = !split_.free().empty() && loosely_held(component, components, holds.held);
    if (loose)
      warnings_.push_back("rotation_invariant: a component is held by fewer than three non-collinear vertices, "
                          "so it may turn freely about them; the solution nearest the 'laplacian' method's is used");
    SparseMatrix system = implicit_transform_system();
    clock.mark("implicit-transform rows (3n)");
    const Ordering blocks = restricted_ordering(*ordering, identity_index(n), 3);  // vertex v: unknowns 3v .. 3v + 2
    implicit_system_ = ConstrainedQuadratic::least_squares(std::move(system), split_.interleaved(3), interleaved(soft, 3),
                                                           loose ? 1e-6 : 0.0, CholeskyKind::Supernodal, &blocks);
    clock.add(implicit_system_.stages(), "implicit 3n: ");
    if (!implicit_system_.factorised())
      throw std::invalid_argument("faces: the mesh's rotation-invariant system could not be factorised (degenerate geometry)");
  }
  // ARAP: L_ff, the global step (Sorkine and Alexa 2007, eq. 9). Laplacian: the normal equations of
  // min ||L x' - delta||^2 over the free vertices (Sorkine et al. 2004, eq. 5), solved for the
  // displacement. Soft constraints add w^2 on their diagonal.
  laplacian_system_ = settings.method == SurfaceMethod::Arap
                          ? ConstrainedQuadratic::quadratic(laplacian_, split_, std::move(soft), CholeskyKind::Supernodal,
                                                            ordering.get())
                          : ConstrainedQuadratic::least_squares(laplacian_, split_, std::move(soft), 0.0,
                                                                CholeskyKind::Supernodal, ordering.get());
  clock.add(laplacian_system_.stages(), settings.method == SurfaceMethod::Arap ? "L_ff: " : "L^T L: ");
  if (!laplacian_system_.factorised())
    throw std::invalid_argument("faces: the mesh's Laplacian system could not be factorised (degenerate geometry)");
}

void SurfaceDeformer::forget_remembered_orderings() { deformkit::forget_remembered_orderings(); }

SurfaceDeformer::Matrix SurfaceDeformer::fixed_positions(const double* targets) const {
  Matrix fixed(Eigen::Index(split_.fixed().size()), 3);
  for (std::size_t i = 0; i < split_.fixed().size(); ++i) fixed.row(Eigen::Index(i)) = rest_.row(split_.fixed()[i]);
  for (std::size_t h = 0; h < handles_.size(); ++h)
    if (split_.is_fixed(handles_[h]))
      fixed.row(split_.fixed_index(handles_[h])) = Eigen::RowVector3d(targets[3 * h], targets[3 * h + 1], targets[3 * h + 2]);
  return fixed;
}

SurfaceDeformer::Matrix SurfaceDeformer::soft_targets(const double* targets) const {
  const std::vector<int>& soft = laplacian_system_.soft().unknowns;
  Matrix c(Eigen::Index(soft.size()), 3);
  for (std::size_t k = 0; k < soft.size(); ++k) {
    const int h = soft_handle_[k];
    c.row(Eigen::Index(k)) = h < 0 ? Matrix(rest_.row(soft[k])) :
        Matrix(Eigen::RowVector3d(targets[3 * h], targets[3 * h + 1], targets[3 * h + 2]));
  }
  return c;
}

SurfaceDeformer::Matrix SurfaceDeformer::with_fixed(const Matrix& fixed) const {
  Matrix x = rest_;
  for (std::size_t i = 0; i < split_.fixed().size(); ++i) x.row(split_.fixed()[i]) = fixed.row(Eigen::Index(i));
  return x;
}

std::vector<double> SurfaceDeformer::deform(const double* targets, const double* initial) {
  require_finite_rows(targets, handles_.size(), "handle_targets");
  if (initial) require_finite_rows(initial, vertex_count(), "initial");
  const std::lock_guard<std::mutex> lock(deforming_);
  const Matrix fixed = fixed_positions(targets), pulls = soft_targets(targets);
  energy_.clear();
  const Matrix x = settings_.method == SurfaceMethod::Laplacian         ? deform_laplacian(fixed, pulls)
                   : settings_.method == SurfaceMethod::RotationInvariant ? deform_rotation_invariant(fixed, pulls)
                                                                          : deform_arap(fixed, pulls, initial);
  if (!x.allFinite())
    throw std::invalid_argument("handle_targets: the solve overflowed (targets too far from the mesh)");
  // ARAP kept its energies in units of length_unit_^2 (docs/math/surface.md, "At any scale").
  const int unit_exponent = std::ilogb(length_unit_);
  for (double& e : energy_) {
    const double scaled = e;
    e = std::ldexp(e, 2 * unit_exponent);  // exact, and no unit^2 to overflow on its own
    if (!std::isfinite(e)) {
      std::ostringstream message;
      message << "points: the ARAP energy of the result, about 10^" << std::fixed << std::setprecision(1)
              << std::log10(scaled) + 2.0 * std::log10(length_unit_)
              << ", is beyond a double (it grows as the mesh's size squared): scale the mesh and the targets down";
      energy_.clear();
      throw std::invalid_argument(message.str());
    }
  }
  std::vector<double> out(3 * rest_.rows());
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(out.data(), rest_.rows(), 3) = x;
  return out;
}

// The linear methods solve for the displacement from rest (M rest = 0 exactly in exact
// arithmetic), so that handles at rest give the rest mesh to the last bit on any mesh, however
// ill-conditioned its clamped weights make the system.
SurfaceDeformer::Displacement SurfaceDeformer::displacement(const Matrix& fixed, const Matrix& pulls) const {
  const std::vector<int>& soft = laplacian_system_.soft().unknowns;
  Displacement d{Matrix(fixed.rows(), 3), Matrix(pulls.rows(), 3), false};
  for (std::size_t i = 0; i < split_.fixed().size(); ++i)
    d.moved.row(Eigen::Index(i)) = fixed.row(Eigen::Index(i)) - rest_.row(split_.fixed()[i]);
  for (std::size_t k = 0; k < soft.size(); ++k) d.pulled.row(Eigen::Index(k)) = pulls.row(Eigen::Index(k)) - rest_.row(soft[k]);
  d.at_rest = d.moved.isZero(0.0) && d.pulled.isZero(0.0);
  return d;
}

void SurfaceDeformer::add_to_free(Matrix& x, const Eigen::MatrixXd& free_displacement) const {
  for (std::size_t i = 0; i < split_.free().size(); ++i) x.row(split_.free()[i]) += free_displacement.row(Eigen::Index(i));
}

// Sorkine et al. 2004, eq. 5: least squares on the differential coordinates, for the displacement.
SurfaceDeformer::Matrix SurfaceDeformer::deform_laplacian(const Matrix& fixed, const Matrix& pulls) const {
  Matrix x = with_fixed(fixed);
  const Displacement d = displacement(fixed, pulls);
  if (split_.free().empty() || d.at_rest) return x;
  add_to_free(x, laplacian_system_.solve_free({}, d.moved, d.pulled));
  return x;
}

}  // namespace deformkit
