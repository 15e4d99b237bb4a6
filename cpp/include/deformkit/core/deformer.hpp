#pragma once
// The interface every spatial deformer shares: positions, Jacobians and what follows from them.
#include "deformkit/core/types.hpp"
#include "deformkit/core/validation.hpp"

#include <memory>
#include <string>
#include <vector>

namespace deformkit {

// Points are n x 3 row-major arrays; Jacobians n x 3 x 3 row-major (J[i][r][c] = dF_r/dx_c).
class Deformer {
 public:
  virtual ~Deformer() = default;

  // out may alias in. Throws std::invalid_argument naming `points` when a row is not finite, and
  // when a finite row maps to a non-finite position (parameters that overflow there).
  void deform(const float* in, float* out, std::size_t n) const;
  void deform(const double* in, double* out, std::size_t n) const;
  // As deform, for input already known to be finite (a previous stage's output): an in-place
  // call then skips the check that must otherwise precede overwriting the input.
  void deform_verified(const float* in, float* out, std::size_t n) const;
  void deform_verified(const double* in, double* out, std::size_t n) const;
  // Throws as deform does for a finite row whose Jacobian is not finite; with float32_result, also
  // for one whose entries do not fit a float (the caller hands float32 back).
  void jacobian(const double* in, double* jac, std::size_t n, bool float32_result = false) const;
  // F(x) - x: what an offset-based consumer (Blender's Geometry Nodes) adds to the points.
  // Throws as deform does where F(x) - x overflows although F(x) does not.
  void displacement(const float* in, float* out, std::size_t n) const;
  void displacement(const double* in, double* out, std::size_t n) const;

  // True when the map is the identity for every point (zero angle, factor or curvature, control
  // points at rest): deform then returns its input bit for bit, however large, and J = I.
  virtual bool is_identity() const { return false; }

  // Who an overflow at a point is blamed on: docs/errors.md, "Overflow blames the argument at fault".
  // A point with a coordinate of magnitude point_magnitude(the result dtype's largest
  // value) or more is the caller's (`points`): the default is point_range, less for a map that
  // grows faster than quadratically. A point within it that overflows is the parameters' fault,
  // named as the user gives them by overflow_parameters ("rate, limits, profile, frame"; empty:
  // "the parameters").
  virtual double point_magnitude(double limit) const { return point_range(limit); }
  virtual std::string overflow_parameters() const { return ""; }

  // Per-point blend between the original and the deformed position (Blender's vertex group):
  // x' = x + w (F(x) - x), so J' = (1 - w) I + w J. Each weight must lie in [0, 1], Blender's
  // range, so that x' lies between x and F(x) and is finite wherever F(x) is.
  void set_weights(std::vector<double> weights);
  const std::vector<double>& weights() const { return weights_ ? *weights_ : no_weights(); }
  // The same weights as `other`, shared rather than copied: a deformer made again with new
  // settings for the same vertex group (a parameter edit) costs nothing per point.
  void share_weights(const Deformer& other) { weights_ = other.weights_; }

 protected:
  // Return false when some input or output row is not finite (the output is then unspecified).
  virtual bool deform_impl(const float* in, float* out, std::size_t n) const = 0;
  virtual bool deform_impl(const double* in, double* out, std::size_t n) const = 0;
  // Return true only when every input row and every entry of J was seen finite (jacobian() then
  // skips its two checking passes over them, a third of its memory traffic); false leaves the
  // checks to jacobian().
  virtual bool jacobian_impl(const double* in, double* jac, std::size_t n) const = 0;
  // w (F(x) - x) in one pass (weights: null, or one per row, the deformer's own): false (the
  // default) leaves the call to deform then a subtraction, which also names any error; true only
  // when every row was finite.
  virtual bool displacement_impl(const float*, float*, std::size_t, const double*) const { return false; }
  virtual bool displacement_impl(const double*, double*, std::size_t, const double*) const { return false; }
  // Fast paths of transform_normals and volume_ratio for all n rows, the weights applied as
  // jacobian() applies them. Return false to leave the work (and any error) to the generic path
  // through jacobian(), which then recomputes every row.
  virtual bool normals_impl(const double*, const double*, double*, std::size_t) const { return false; }
  virtual bool normals_impl(const float*, const float*, float*, std::size_t) const { return false; }
  virtual bool volume_ratio_impl(const double*, double*, std::size_t) const { return false; }
  friend void transform_normals(const Deformer&, const double*, const double*, double*, std::size_t);
  friend void transform_normals(const Deformer&, const float*, const float*, float*, std::size_t);
  friend void volume_ratio(const Deformer&, const double*, double*, std::size_t, bool);

 private:
  template <class T>
  void deform_checked(const T* in, T* out, std::size_t n, bool input_verified) const;
  template <class T>
  void deform_unchecked(const T* in, T* out, std::size_t n, bool input_verified) const;
  template <class T>
  void displace(const T* in, T* out, std::size_t n) const;
  static const std::vector<double>& no_weights();
  std::shared_ptr<const std::vector<double>> weights_;  // null: none; shared by share_weights
};

using DeformerPtr = std::shared_ptr<const Deformer>;

// Unit normals carried by the map: N' = det(J) J^-T N = cof(J) N, then normalised, for normals of
// any non-zero length. A zero normal, or one whose plane the map collapses (cof(J) N = 0), gives 0.
void transform_normals(const Deformer& d, const double* points, const double* normals,
                       double* out, std::size_t n);
// The same in float32 (what a viewport draws): computed in float where the deformer has a float
// path, else in double and rounded once.
void transform_normals(const Deformer& d, const float* points, const float* normals, float* out, std::size_t n);
// Local volume ratio det(J). Throws as deform does where det(J) overflows (a double, or a float
// with float32_result).
void volume_ratio(const Deformer& d, const double* points, double* out, std::size_t n,
                  bool float32_result = false);

// J = I at each of n points (n row-major 3x3 blocks): the Jacobians of a map that leaves points
// where they are.
void identity_jacobians(double* jac, std::size_t n);

// cof(J) = det(J) J^-T, defined (and continuous) also where J is singular.
Mat3 cofactor(const Mat3& j);

// Blender's vertex-group blend x + w (f - x) for w in [0, 1]; where f - x overflows, the equal
// (1 - w) x + w f, which lies between x and f and so is finite whenever both are.
inline double blend_toward(double x, double f, double w) {
  const double d = f - x;
  if (d - d == 0.0) return x + w * d;
  return (1.0 - w) * x + w * f;
}

}  // namespace deformkit
