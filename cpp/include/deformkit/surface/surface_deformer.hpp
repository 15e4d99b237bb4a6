#pragma once
// Surface deformers on a triangle mesh: Laplacian editing (Sorkine et al. 2004) and
// as-rigid-as-possible deformation (Sorkine and Alexa 2007), with the system over the free
// vertices factorised once at construction, so that moving handles only back-substitutes.
#include "deformkit/surface/cotangent_laplacian.hpp"
#include "deformkit/core/stages.hpp"
#include "deformkit/core/types.hpp"

#include "deformkit/numerics/constrained_quadratic.hpp"

#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace deformkit {

enum class SurfaceMethod { Laplacian, RotationInvariant, Arap };

struct SurfaceSettings {
  SurfaceMethod method = SurfaceMethod::Arap;
  bool uniform_weights = false;
  int iterations = 10;     // ARAP local/global iterations; rotation-invariant rotation passes
  double tolerance = 0.0;  // > 0: stop when the relative energy decrease falls below it
  // ARAP: > 0 mixes the last `anderson` local/global steps (Anderson acceleration, Peng et al.
  // 2018); 0 is the plain alternation (Sorkine and Alexa 2007), step for step as CGAL's.
  int anderson = 0;
  // None: anchors and handles are hard constraints (met exactly). w: soft, each adding
  // w^2 ||x_i - c_i||^2 to the least-squares energy (Sorkine et al. 2004, eq. 5), 2 w^2 ||.||^2 to
  // ARAP's, whose sum over edges counts every edge twice. w must lie in [kMinConstraintWeight,
  // kMaxConstraintWeight].
  std::optional<double> constraint_weight;
};

// The Laplacian's weights are dimensionless and near 1 (cotangents, or 1), so w^2 is measured
// against 1: beyond 1e16 the Laplacian terms are lost in the rounding of the soft ones (the
// solve is the hard one), below 1e-8 the soft terms are lost in the Laplacian's (they hold
// nothing, and a mesh held only by them is singular).
constexpr double kMinConstraintWeight = 1e-4, kMaxConstraintWeight = 1e8;

class SurfaceDeformer {
 public:
  // Polygons are fanned into triangles. Throws std::invalid_argument naming anchors, handles or
  // roi for bad indices, and iterations or tolerance for bad settings.
  SurfaceDeformer(PolygonMesh mesh, std::vector<int> anchors, std::vector<int> handles,
                  const std::optional<std::vector<int>>& roi, SurfaceSettings settings);

  // New positions (3n) with the handles at targets (3 per handle). Records energy() for ARAP.
  // initial (3n, or null): ARAP starts from the rotations that best fit these positions (e.g. the
  // previous frame's result) instead of R = I, so that a handle moved a little converges in a few
  // iterations; the linear methods have nothing to start from and ignore it. Throws
  // std::invalid_argument naming initial for a non-finite row. Calls on one deformer from several
  // threads run one after the other.
  std::vector<double> deform(const double* targets, const double* initial = nullptr);

  std::size_t vertex_count() const { return mesh_.vertex_count(); }
  std::size_t handle_count() const { return handles_.size(); }
  std::size_t free_count() const { return split_.free().size(); }
  std::size_t factor_nonzeros() const { return laplacian_system_.factor_nonzeros(); }
  const SurfaceSettings& settings() const { return settings_; }
  const std::vector<std::string>& warnings() const { return warnings_; }
  const Stages& bind_stages() const { return bind_stages_; }  // where the construction spent its time
  // A bind remembers the fill-reducing ordering of its connectivity for the next one; benchmarks
  // forget it to time a first bind again.
  static void forget_remembered_orderings();
  std::vector<double> energy() const {
    const std::lock_guard<std::mutex> lock(deforming_);
    return energy_;
  }

 private:
  using Matrix = Eigen::Matrix<double, Eigen::Dynamic, 3>;
  // Hard constraints and the soft ones' pull at these targets: the fixed vertices' positions (in
  // split_.fixed() order) and the soft vertices' targets (a handle's target, an anchor's rest).
  Matrix fixed_positions(const double* targets) const;
  Matrix soft_targets(const double* targets) const;
  Matrix with_fixed(const Matrix& fixed) const;  // rest, the fixed vertices at `fixed`
  struct Displacement {
    Matrix moved, pulled;  // fixed positions and soft targets minus their rest
    bool at_rest;          // both exactly zero
  };
  Displacement displacement(const Matrix& fixed, const Matrix& pulls) const;
  void add_to_free(Matrix& x, const Eigen::MatrixXd& free_displacement) const;
  Matrix deform_laplacian(const Matrix& fixed, const Matrix& pulls) const;
  Matrix deform_rotation_invariant(const Matrix& fixed, const Matrix& pulls) const;
  Matrix deform_arap(const Matrix& fixed, const Matrix& pulls, const double* initial);
  void fit_rotations(const Matrix& x, std::vector<Mat3>& rotations) const;
  Matrix arap_rhs(const std::vector<Mat3>& rotations) const;
  // The ARAP energy in units of length_unit_ squared, so that it neither overflows nor underflows
  // on its way (deform() scales it back once, and refuses a result whose energy is beyond a double).
  double arap_energy(const Matrix& x, const std::vector<Mat3>& rotations) const;
  // 2^k with the rows' bounding box's largest side in [2^k, 2^(k+1)), or 1 for coincident rows.
  static double length_unit(const Matrix& rows);
  Matrix accelerate_arap(Matrix x, std::vector<Mat3>& rotations, const std::function<Matrix()>& global_step,
                         const std::function<double(const Matrix&, const std::vector<Mat3>&)>& energy_of,
                         const std::function<bool()>& converged);
  SparseMatrix implicit_transform_system() const;
  bool loosely_held(const std::vector<int>& component, int components, const std::vector<char>& held) const;

  PolygonMesh mesh_;  // triangulated
  SurfaceSettings settings_;
  std::vector<int> handles_;
  UnknownSplit split_;               // vertices solved for (free) and held exactly (fixed)
  std::vector<int> soft_handle_;     // per softly held vertex: its handle, or -1 (an anchor)
  Matrix rest_;
  SparseMatrix laplacian_;           // with the clamped weights
  std::vector<std::vector<std::pair<int, double>>> neighbors_;  // (j, w_ij)
  Matrix delta_;                     // L rest: the differential coordinates
  // ARAP: the quadratic form of L (its global step); Laplacian and rotation-invariant: the least
  // squares |L x - delta|^2. Rotation-invariant also: the 3n x 3n implicit-transform system.
  ConstrainedQuadratic laplacian_system_, implicit_system_;
  std::vector<std::string> warnings_;
  Stages bind_stages_;
  std::vector<double> energy_;
  double length_unit_ = 1.0;  // length_unit(rest_)
  mutable std::mutex deforming_;  // deform() records energy_: one call at a time per deformer
};

}  // namespace deformkit
