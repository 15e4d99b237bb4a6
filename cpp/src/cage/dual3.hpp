#pragma once
// Forward-mode dual numbers with three partial derivatives: a templated formula evaluated on Dual3
// gives its value and its exact gradient with respect to the point (no finite differences).
#include <cmath>

namespace deformkit {

struct Dual3 {
  double v = 0.0;
  double d[3] = {0.0, 0.0, 0.0};

  Dual3() = default;
  Dual3(double value) : v(value) {}  // NOLINT: constants promote implicitly, as doubles do
  static Dual3 variable(double value, int axis) {
    Dual3 x(value);
    x.d[axis] = 1.0;
    return x;
  }
};

inline Dual3 operator+(const Dual3& a, const Dual3& b) {
  Dual3 r(a.v + b.v);
  for (int k = 0; k < 3; ++k) r.d[k] = a.d[k] + b.d[k];
  return r;
}
inline Dual3 operator-(const Dual3& a, const Dual3& b) {
  Dual3 r(a.v - b.v);
  for (int k = 0; k < 3; ++k) r.d[k] = a.d[k] - b.d[k];
  return r;
}
inline Dual3 operator-(const Dual3& a) {
  Dual3 r(-a.v);
  for (int k = 0; k < 3; ++k) r.d[k] = -a.d[k];
  return r;
}
inline Dual3 operator*(const Dual3& a, const Dual3& b) {
  Dual3 r(a.v * b.v);
  for (int k = 0; k < 3; ++k) r.d[k] = a.d[k] * b.v + a.v * b.d[k];
  return r;
}
inline Dual3 operator/(const Dual3& a, const Dual3& b) {
  const double inv = 1.0 / b.v;
  Dual3 r(a.v * inv);
  for (int k = 0; k < 3; ++k) r.d[k] = (a.d[k] - r.v * b.d[k]) * inv;
  return r;
}
inline Dual3& operator+=(Dual3& a, const Dual3& b) { return a = a + b; }
inline Dual3& operator-=(Dual3& a, const Dual3& b) { return a = a - b; }

inline double value_of(double x) { return x; }
inline double value_of(const Dual3& x) { return x.v; }

inline Dual3 sqrt(const Dual3& a) {
  Dual3 r(std::sqrt(a.v));
  const double s = r.v > 0.0 ? 0.5 / r.v : 0.0;  // the gradient of |e| at e = 0 is taken as 0
  for (int k = 0; k < 3; ++k) r.d[k] = a.d[k] * s;
  return r;
}
inline Dual3 asin(const Dual3& a) {
  Dual3 r(std::asin(a.v));
  const double q = 1.0 - a.v * a.v;
  const double s = q > 0.0 ? 1.0 / std::sqrt(q) : 0.0;
  for (int k = 0; k < 3; ++k) r.d[k] = a.d[k] * s;
  return r;
}

}  // namespace deformkit
