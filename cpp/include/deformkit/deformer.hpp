#pragma once
// The interface every spatial deformer shares: positions, Jacobians and what follows from them.
#include "deformkit/types.hpp"

#include <memory>
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
  void jacobian(const double* in, double* jac, std::size_t n) const;
  // F(x) - x: what an offset-based consumer (Blender's Geometry Nodes) adds to the points.
  void displacement(const float* in, float* out, std::size_t n) const;
  void displacement(const double* in, double* out, std::size_t n) const;

  // Per-point blend between the original and the deformed position (Blender's vertex group):
  // x' = x + w (F(x) - x), so J' = (1 - w) I + w J.
  void set_weights(std::vector<double> weights);
  const std::vector<double>& weights() const { return weights_; }

 protected:
  // Return false when some input or output row is not finite (the output is then unspecified).
  virtual bool deform_impl(const float* in, float* out, std::size_t n) const = 0;
  virtual bool deform_impl(const double* in, double* out, std::size_t n) const = 0;
  virtual void jacobian_impl(const double* in, double* jac, std::size_t n) const = 0;

 private:
  template <class T>
  void deform_checked(const T* in, T* out, std::size_t n, bool input_verified) const;
  std::vector<double> weights_;
};

using DeformerPtr = std::shared_ptr<const Deformer>;

// Unit normals carried by the map: N' = det(J) J^-T N = cof(J) N, then normalised.
void transform_normals(const Deformer& d, const double* points, const double* normals,
                       double* out, std::size_t n);
// Local volume ratio det(J).
void volume_ratio(const Deformer& d, const double* points, double* out, std::size_t n);

// cof(J) = det(J) J^-T, defined (and continuous) also where J is singular.
Mat3 cofactor(const Mat3& j);

// Throws std::invalid_argument naming `argument` and the first non-finite row.
template <class T>
void require_finite_rows(const T* data, std::size_t n, const char* argument);

}  // namespace deformkit
