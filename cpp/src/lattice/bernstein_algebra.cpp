#include "deformkit/lattice/bernstein_algebra.hpp"

#include <stdexcept>

namespace deformkit {

namespace {

struct BinomialTable {
  double c[kMaxBinomial + 1][kMaxBinomial + 1] = {};
  BinomialTable() {
    for (int n = 0; n <= kMaxBinomial; ++n) {
      c[n][0] = c[n][n] = 1.0;
      for (int k = 1; k < n; ++k) c[n][k] = c[n - 1][k - 1] + c[n - 1][k];
    }
  }
};

const BinomialTable& table() {
  static const BinomialTable t;
  return t;
}

// Multiply (or divide) every coefficient by its three binomials.
void scale_by_binomials(TriPoly& p, bool divide) {
  const auto& t = table();
  const auto& d = p.degree;
  std::size_t e = 0;
  for (int i = 0; i <= d[0]; ++i)
    for (int j = 0; j <= d[1]; ++j) {
      const double bij = t.c[d[0]][i] * t.c[d[1]][j];
      for (int k = 0; k <= d[2]; ++k, ++e) {
        const double b = bij * t.c[d[2]][k];
        p.c[e] = divide ? p.c[e] / b : p.c[e] * b;
      }
    }
}

// out = in elevated along `axis` to degree `to`, scaled form: a convolution with C(r, .).
void elevate_axis(const TriPoly& in, int axis, int to, TriPoly& out) {
  std::array<int, 3> d = in.degree;
  const int from = d[axis], r = to - from;
  d[axis] = to;
  out.reset(d);
  const double* row = table().c[r];
  const std::array<int, 3>& s = in.degree;
  for (int i = 0; i <= s[0]; ++i)
    for (int j = 0; j <= s[1]; ++j)
      for (int k = 0; k <= s[2]; ++k) {
        const double v = in.at(i, j, k);
        if (v == 0.0) continue;
        for (int q = 0; q <= r; ++q) {
          const int ii = i + (axis == 0) * q, jj = j + (axis == 1) * q, kk = k + (axis == 2) * q;
          out.at(ii, jj, kk) += v * row[q];
        }
      }
}

}  // namespace

double binomial(int n, int k) {
  if (n < 0 || n > kMaxBinomial || k < 0 || k > n) throw std::out_of_range("binomial: outside the table");
  return table().c[n][k];
}

void to_scaled(TriPoly& p) { scale_by_binomials(p, false); }
void from_scaled(TriPoly& p) { scale_by_binomials(p, true); }

namespace {

// out += sum_t sign_t a_t * b_t, the convolutions fused so that each output row is loaded and
// stored once for all T terms (the loop is bound by those memory operations, not the
// multiplications); the last axis' length N known at compile time (N = 0: any), unrolled.
template <int N, int T>
void fused_rows(const TriPoly* const* a, const TriPoly* const* b, const double* sign, TriPoly& out) {
  const std::array<int, 3> da = a[0]->degree, db = b[0]->degree;
  const int bn1 = db[1] + 1, bn2 = N > 0 ? N : db[2] + 1;
  const int on1 = out.degree[1] + 1, on2 = out.degree[2] + 1;
  std::size_t e = 0;
  for (int i = 0; i <= da[0]; ++i)
    for (int j = 0; j <= da[1]; ++j)
      for (int k = 0; k <= da[2]; ++k, ++e) {
        double v[T];
        bool any = false;
        for (int t = 0; t < T; ++t) {
          v[t] = sign[t] * a[t]->c[e];
          any = any || v[t] != 0.0;
        }
        if (!any) continue;
        for (int p = 0; p <= db[0]; ++p)
          for (int q = 0; q < bn1; ++q) {
            const std::size_t from = (std::size_t(p) * bn1 + q) * bn2;
            const double* src[T];
            for (int t = 0; t < T; ++t) src[t] = &b[t]->c[from];
            double* dst = &out.c[(std::size_t(i + p) * on1 + (j + q)) * on2 + k];
            for (int r = 0; r < bn2; ++r) {
              double acc = dst[r];
              for (int t = 0; t < T; ++t) acc += v[t] * src[t][r];
              dst[r] = acc;
            }
          }
      }
}

template <int T>
void fused_by_length(const TriPoly* const* a, const TriPoly* const* b, const double* sign, TriPoly& out) {
  switch (b[0]->degree[2] + 1) {
    case 1: return fused_rows<1, T>(a, b, sign, out);
    case 2: return fused_rows<2, T>(a, b, sign, out);
    case 3: return fused_rows<3, T>(a, b, sign, out);
    case 4: return fused_rows<4, T>(a, b, sign, out);
    case 5: return fused_rows<5, T>(a, b, sign, out);
    case 6: return fused_rows<6, T>(a, b, sign, out);
    case 7: return fused_rows<7, T>(a, b, sign, out);
    default: return fused_rows<0, T>(a, b, sign, out);
  }
}

}  // namespace

void multiply_scaled(const TriPoly& a, const TriPoly& b, TriPoly& out) {
  if (a.empty() || b.empty()) {
    out.clear();
    return;
  }
  out.reset({a.degree[0] + b.degree[0], a.degree[1] + b.degree[1], a.degree[2] + b.degree[2]});
  const TriPoly* pa = &a;
  const TriPoly* pb = &b;
  const double one = 1.0;
  fused_by_length<1>(&pa, &pb, &one, out);
}

void multiply_sum_scaled(const std::vector<ScaledTerm>& terms, TriPoly& out) {
  const TriPoly* a[3];
  const TriPoly* b[3];
  double sign[3];
  int n = 0;
  for (const ScaledTerm& t : terms) {
    if (t.a->empty() || t.b->empty()) continue;
    if (n == 3) throw std::logic_error("multiply_sum_scaled: at most three terms");
    a[n] = t.a, b[n] = t.b, sign[n] = t.sign;
    ++n;
  }
  if (n == 0) {
    out.clear();
    return;
  }
  for (int t = 1; t < n; ++t)
    if (a[t]->degree != a[0]->degree || b[t]->degree != b[0]->degree)
      throw std::logic_error("multiply_sum_scaled: terms of different degrees");
  out.reset({a[0]->degree[0] + b[0]->degree[0], a[0]->degree[1] + b[0]->degree[1], a[0]->degree[2] + b[0]->degree[2]});
  if (n == 1) fused_by_length<1>(a, b, sign, out);
  else if (n == 2) fused_by_length<2>(a, b, sign, out);
  else fused_by_length<3>(a, b, sign, out);
}

void add_elevated_scaled(const TriPoly& a, TriPoly& acc, TriPoly& scratch) {
  if (a.empty()) return;
  if (a.degree == acc.degree) {
    for (std::size_t e = 0; e < acc.c.size(); ++e) acc.c[e] += a.c[e];
    return;
  }
  thread_local TriPoly other;
  const TriPoly* cur = &a;
  TriPoly* bufs[2] = {&scratch, &other};
  int next = 0;
  for (int axis = 0; axis < 3; ++axis) {
    if (cur->degree[axis] == acc.degree[axis]) continue;
    if (cur->degree[axis] > acc.degree[axis]) throw std::logic_error("add_elevated_scaled: degree too high");
    elevate_axis(*cur, axis, acc.degree[axis], *bufs[next]);
    cur = bufs[next];
    next ^= 1;
  }
  for (std::size_t e = 0; e < acc.c.size(); ++e) acc.c[e] += cur->c[e];
}

void split_half(const TriPoly& p, int axis, TriPoly& low, TriPoly& high) {
  low.reset(p.degree);
  high.reset(p.degree);
  const int n = p.degree[axis];
  const std::array<int, 3> d = p.degree;
  const std::size_t stride = axis == 0 ? std::size_t(d[1] + 1) * (d[2] + 1) : axis == 1 ? std::size_t(d[2] + 1) : 1;
  double work[kMaxBinomial + 1];
  const std::size_t total = p.size();
  for (std::size_t base = 0; base < total; ++base) {
    // base is the first coefficient of a line along `axis` when its index along the axis is 0.
    if ((base / stride) % std::size_t(n + 1) != 0) continue;
    for (int q = 0; q <= n; ++q) work[q] = p.c[base + q * stride];
    // de Casteljau at 1/2: the left edge of the triangle is the low half, the right edge the high.
    low.c[base] = work[0];
    high.c[base + n * stride] = work[n];
    for (int level = 1; level <= n; ++level) {
      for (int q = 0; q <= n - level; ++q) work[q] = 0.5 * (work[q] + work[q + 1]);
      low.c[base + level * stride] = work[0];
      high.c[base + (n - level) * stride] = work[n - level];
    }
  }
}

double evaluate_bernstein(const TriPoly& p, double u, double v, double w) {
  const std::array<int, 3> d = p.degree;
  const double t[3] = {u, v, w};
  std::vector<double> cur(p.c);
  std::array<int, 3> n = d;
  // Reduce the last axis first: cur holds a (n0+1) x (n1+1) x (n2+1) block.
  for (int axis = 2; axis >= 0; --axis) {
    const std::size_t lines = cur.size() / std::size_t(n[axis] + 1);
    std::vector<double> next(lines);
    // Along the last remaining axis the coefficients are contiguous.
    for (std::size_t l = 0; l < lines; ++l) {
      double work[kMaxBinomial + 1];
      for (int q = 0; q <= n[axis]; ++q) work[q] = cur[l * (n[axis] + 1) + q];
      for (int level = 1; level <= n[axis]; ++level)
        for (int q = 0; q <= n[axis] - level; ++q) work[q] = (1.0 - t[axis]) * work[q] + t[axis] * work[q + 1];
      next[l] = work[0];
    }
    cur.swap(next);
    n[axis] = 0;
  }
  return cur[0];
}

}  // namespace deformkit
