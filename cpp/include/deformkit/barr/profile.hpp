#pragma once
// A scalar profile f(z) along a deformer's axis, with f'(z): Barr's r = f(z) (taper) and
// theta = f(z) (twist), Barr 1984 eqs. for taper and twist.
#include <limits>
#include <vector>

namespace deformkit {

enum class Extend { Constant, Linear };

class Profile {
 public:
  // f(z) = offset + slope * clamp(z, lo, hi); lo and hi may be infinite.
  static Profile linear(double offset, double slope,
                        double lo = -std::numeric_limits<double>::infinity(),
                        double hi = std::numeric_limits<double>::infinity());
  // Natural cubic spline through (z_i, f_i): z strictly increasing, at least two samples.
  // Outside [z_0, z_n-1] the profile is held constant or continued along the end tangent.
  static Profile spline(std::vector<double> z, std::vector<double> f, Extend extend = Extend::Constant);

  bool is_linear() const { return knots_.empty(); }
  // f(z) == v for every z.
  bool is_constant(double v) const;
  double value(double z) const;
  double derivative(double z) const;
  void evaluate(double z, double& f, double& df) const;

  // Linear form (valid when is_linear()).
  double offset() const { return offset_; }
  double slope() const { return slope_; }
  double lo() const { return lo_; }
  double hi() const { return hi_; }
  const std::vector<double>& knots() const { return knots_; }
  const std::vector<double>& values() const { return values_; }
  Extend extend() const { return extend_; }

 private:
  double offset_ = 0, slope_ = 0;
  double lo_ = -std::numeric_limits<double>::infinity(), hi_ = std::numeric_limits<double>::infinity();
  std::vector<double> knots_, values_, second_;  // spline: z_i, f_i, f''_i
  Extend extend_ = Extend::Constant;
};

}  // namespace deformkit
