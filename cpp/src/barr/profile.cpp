#include "deformkit/barr/profile.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace deformkit {

Profile Profile::linear(double offset, double slope, double lo, double hi) {
  if (!std::isfinite(offset) || !std::isfinite(slope))
    throw std::invalid_argument("profile: offset and slope must be finite");
  if (std::isnan(lo) || std::isnan(hi) || lo > hi || lo == std::numeric_limits<double>::infinity() ||
      hi == -std::numeric_limits<double>::infinity())
    throw std::invalid_argument("limits: expected lo <= hi with lo < +inf and hi > -inf, got (" + std::to_string(lo) +
                                ", " + std::to_string(hi) + ")");
  Profile p;
  p.offset_ = offset;
  p.slope_ = slope;
  p.lo_ = lo;
  p.hi_ = hi;
  return p;
}

// Natural cubic spline: tridiagonal system for the second derivatives with M_0 = M_n-1 = 0
// (solved by the Thomas algorithm; the matrix is strictly diagonally dominant).
Profile Profile::spline(std::vector<double> z, std::vector<double> f, Extend extend) {
  const std::size_t n = z.size();
  if (n != f.size())
    throw std::invalid_argument("profile: " + std::to_string(n) + " positions but " +
                                std::to_string(f.size()) + " values");
  if (n < 2) throw std::invalid_argument("profile: needs at least two samples, got " + std::to_string(n));
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(z[i]) || !std::isfinite(f[i]))
      throw std::invalid_argument("profile: sample " + std::to_string(i) + " is not finite");
    if (i > 0 && !(z[i] > z[i - 1]))
      throw std::invalid_argument("profile: positions must be strictly increasing (sample " +
                                  std::to_string(i) + ")");
  }
  std::vector<double> m(n, 0.0);
  if (n > 2) {
    std::vector<double> diag(n, 0.0), rhs(n, 0.0);
    for (std::size_t i = 1; i + 1 < n; ++i) {
      const double h0 = z[i] - z[i - 1], h1 = z[i + 1] - z[i];
      diag[i] = 2.0 * (h0 + h1);
      rhs[i] = 6.0 * ((f[i + 1] - f[i]) / h1 - (f[i] - f[i - 1]) / h0);
    }
    for (std::size_t i = 2; i + 1 < n; ++i) {  // forward elimination
      const double h = z[i] - z[i - 1], w = h / diag[i - 1];
      diag[i] -= w * h;
      rhs[i] -= w * rhs[i - 1];
    }
    for (std::size_t i = n - 2; i >= 1; --i) {  // back substitution
      const double upper = i + 2 < n ? (z[i + 1] - z[i]) * m[i + 1] : 0.0;
      m[i] = (rhs[i] - upper) / diag[i];
    }
  }
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(m[i]))
      throw std::invalid_argument("profile: the spline through these samples overflows (sample " + std::to_string(i) +
                                  "); spread the positions or scale the values");
  Profile p;
  p.knots_ = std::move(z);
  p.values_ = std::move(f);
  p.second_ = std::move(m);
  p.extend_ = extend;
  return p;
}

void Profile::evaluate(double z, double& f, double& df) const {
  if (is_linear()) {
    const bool inside = z >= lo_ && z <= hi_;
    f = offset_ + slope_ * std::clamp(z, lo_, hi_);
    df = inside ? slope_ : 0.0;
    return;
  }
  const std::size_t n = knots_.size();
  auto segment = [&](std::size_t i, double x) {
    const double h = knots_[i + 1] - knots_[i];
    const double a = (knots_[i + 1] - x) / h, b = (x - knots_[i]) / h;
    f = a * values_[i] + b * values_[i + 1] +
        ((a * a * a - a) * second_[i] + (b * b * b - b) * second_[i + 1]) * h * h / 6.0;
    df = (values_[i + 1] - values_[i]) / h +
         (-(3.0 * a * a - 1.0) * second_[i] + (3.0 * b * b - 1.0) * second_[i + 1]) * h / 6.0;
  };
  if (z < knots_.front() || z > knots_.back()) {
    const bool below = z < knots_.front();
    const double end = below ? knots_.front() : knots_.back();
    segment(below ? 0 : n - 2, end);
    if (extend_ == Extend::Constant) {
      df = 0.0;
    } else {
      f += df * (z - end);
    }
    return;
  }
  const auto it = std::upper_bound(knots_.begin(), knots_.end(), z);
  const std::size_t i = std::min<std::size_t>(n - 2, static_cast<std::size_t>(it - knots_.begin()) - 1);
  segment(i, z);
}

double Profile::value(double z) const {
  double f, df;
  evaluate(z, f, df);
  return f;
}

double Profile::derivative(double z) const {
  double f, df;
  evaluate(z, f, df);
  return df;
}

bool Profile::is_constant(double v) const {
  if (is_linear()) return slope_ == 0.0 ? offset_ == v : lo_ == hi_ && value(lo_) == v;
  // A natural spline through equal values is that value, and so are its end tangents.
  for (double f : values_)
    if (f != v) return false;
  return true;
}

}  // namespace deformkit
