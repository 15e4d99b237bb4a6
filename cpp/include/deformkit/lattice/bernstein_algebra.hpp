#pragma once
// Trivariate Bernstein polynomials over [0,1]^3: products, degree elevation and de Casteljau
// subdivision, what the Jacobian bounds of the box lattices are made of (docs/math/lattice.md,
// "Certified volume-ratio bounds").
//
// Products and elevation work in the scaled form c~_ijk = C(l,i) C(m,j) C(n,k) b_ijk, in which
// the product of two polynomials is the plain convolution of their coefficients (Sederberg-Parry
// 1986, section 5; Johnen, Remacle, Geuzaine 2013, eq. 11): the binomial ratios of the Bernstein
// product come in by the scaling and its inverse.
#include <array>
#include <cstddef>
#include <vector>

namespace deformkit {

// Coefficients b[(i * (m+1) + j) * (n+1) + k] of degree (l, m, n); no coefficients: the zero
// polynomial of no particular degree (a column of the Jacobian that is identically zero).
struct TriPoly {
  std::array<int, 3> degree{0, 0, 0};
  std::vector<double> c;

  bool empty() const { return c.empty(); }
  std::size_t size() const { return std::size_t(degree[0] + 1) * (degree[1] + 1) * (degree[2] + 1); }
  void reset(const std::array<int, 3>& d, double fill = 0.0) {
    degree = d;
    c.assign(size(), fill);
  }
  void clear() { c.clear(); }
  double& at(int i, int j, int k) { return c[(std::size_t(i) * (degree[1] + 1) + j) * (degree[2] + 1) + k]; }
  double at(int i, int j, int k) const { return c[(std::size_t(i) * (degree[1] + 1) + j) * (degree[2] + 1) + k]; }
};

// C(n, k) for n <= kMaxBinomial, exact in double (C(56, 28) < 2^53).
constexpr int kMaxBinomial = 56;
double binomial(int n, int k);

// Bernstein <-> scaled form, in place.
void to_scaled(TriPoly& p);
void from_scaled(TriPoly& p);

// out = a * b in the scaled form (out must not be a or b); empty when either is.
void multiply_scaled(const TriPoly& a, const TriPoly& b, TriPoly& out);
// out = sum of sign * a * b over at most three terms in the scaled form, all a of one degree and
// all b of one degree; empty terms are skipped, and out is empty when all are.
struct ScaledTerm {
  const TriPoly* a;
  const TriPoly* b;
  double sign;
};
void multiply_sum_scaled(const std::vector<ScaledTerm>& terms, TriPoly& out);
// acc += a elevated to acc's degree (scaled form): elevation by r along an axis is the product
// with (t + (1 - t))^r, whose scaled coefficients are C(r, j). acc must have a's degree or more.
void add_elevated_scaled(const TriPoly& a, TriPoly& acc, TriPoly& scratch);

// The two halves of p (Bernstein form) along `axis`, split at 1/2 by de Casteljau's algorithm.
void split_half(const TriPoly& p, int axis, TriPoly& low, TriPoly& high);

// The value at (u, v, w) in [0,1]^3 of p in Bernstein form (de Casteljau, axis by axis).
double evaluate_bernstein(const TriPoly& p, double u, double v, double w);

}  // namespace deformkit
