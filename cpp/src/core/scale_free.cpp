#include "core/scale_free.hpp"

#include "deformkit/core/deformer.hpp"

#include <cmath>

namespace deformkit {

namespace {

// Entries in [2^-300, 2^300] keep every product of three in the normal range.
constexpr double kSafeLow = 0x1p-300, kSafeHigh = 0x1p300;

bool products_are_safe(const Mat3& j) {
  const double big = j.cwiseAbs().maxCoeff();
  double small = big;
  for (int e = 0; e < 9; ++e)
    if (j(e) != 0.0) small = std::min(small, std::abs(j(e)));
  return big <= kSafeHigh && small >= kSafeLow;
}

int exponent_of(double magnitude) { return magnitude > 0.0 ? std::ilogb(magnitude) : 0; }

// J = diag(2^row) K diag(2^col), every row and column of K with largest entry in [1, 2).
Mat3 equilibrate(const Mat3& j, int row[3], int col[3]) {
  Mat3 k = j;
  for (int r = 0; r < 3; ++r) {
    row[r] = exponent_of(k.row(r).cwiseAbs().maxCoeff());
    for (int c = 0; c < 3; ++c) k(r, c) = std::ldexp(k(r, c), -row[r]);
  }
  for (int c = 0; c < 3; ++c) {
    col[c] = exponent_of(k.col(c).cwiseAbs().maxCoeff());
    for (int r = 0; r < 3; ++r) k(r, c) = std::ldexp(k(r, c), -col[c]);
  }
  return k;
}

// diag(2^-e) v up to a positive factor, chosen so that the largest component is near 1.
Vec3 divide_by_powers(const Vec3& v, const int e[3]) {
  int top = 0;
  bool any = false;
  for (int a = 0; a < 3; ++a)
    if (v[a] != 0.0) {
      const int x = std::ilogb(v[a]) - e[a];
      top = any ? std::max(top, x) : x;
      any = true;
    }
  Vec3 out;
  for (int a = 0; a < 3; ++a) out[a] = std::ldexp(v[a], -e[a] - top);
  return out;
}

}  // namespace

Vec3 normalized_or_zero(const Vec3& v) {
  const double big = v.cwiseAbs().maxCoeff();
  if (!(big > 0.0)) return Vec3::Zero();
  const Vec3 u = v / big;  // components in [-1, 1], the largest +-1: the norm cannot underflow
  return u / u.norm();
}

Vec3 normal_direction(const Mat3& j, const Vec3& n) {
  const Vec3 unit = normalized_or_zero(n);
  if (products_are_safe(j)) return normalized_or_zero(cofactor(j) * unit);
  // cof(diag(d)) = det(diag(d)) diag(d)^-1, and a positive factor does not change the direction.
  int row[3], col[3];
  const Mat3 k = equilibrate(j, row, col);
  return normalized_or_zero(divide_by_powers(cofactor(k) * divide_by_powers(unit, col), row));
}

double scaled_determinant(const Mat3& j) {
  if (products_are_safe(j)) return j.determinant();
  int row[3], col[3];
  const Mat3 k = equilibrate(j, row, col);
  return std::ldexp(k.determinant(), row[0] + row[1] + row[2] + col[0] + col[1] + col[2]);
}

}  // namespace deformkit
