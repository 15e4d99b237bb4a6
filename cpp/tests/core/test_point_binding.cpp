// The bind seam: the CSR weight table's product against a dense one, and the BoundDeformer's
// policy (count, blend, overflow report, identity, dtype, ownership) through a test double that
// is nothing but a weight table per point, as cage coordinates and RBF will be.
#include "test_util.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

using namespace deformkit;
using namespace deformkit::test;

namespace {

// Throws unless `f` throws std::invalid_argument with exactly `message`.
template <class F>
void expect_message(F&& f, const std::string& message) {
  try {
    f();
    ADD_FAILURE() << "no exception, expected: " << message;
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), message);
  }
}

// A random table: some empty rows, some rows with one entry, columns sorted per row.
WeightTable random_table(std::size_t rows, std::size_t columns, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::bernoulli_distribution keep(0.35);
  WeightTable w;
  for (std::size_t r = 0; r < rows; ++r) {
    for (std::size_t c = 0; c < columns; ++c)
      if (r % 7 != 3 && keep(rng)) {
        w.indices.push_back(std::int32_t(c));
        w.values.push_back(u(rng));
      }
    w.indptr.push_back(std::int64_t(w.indices.size()));
  }
  return w;
}

Eigen::MatrixXd dense(const WeightTable& w, std::size_t columns) {
  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(Eigen::Index(w.rows()), Eigen::Index(columns));
  for (std::size_t r = 0; r < w.rows(); ++r)
    for (auto k = w.indptr[r]; k < w.indptr[r + 1]; ++k) d(Eigen::Index(r), w.indices[k]) += w.values[k];
  return d;
}

struct TableBinding : PointBinding {
  WeightTable weights;
  std::vector<double> points_d;
  std::vector<float> points_f;
};

// F(x) = x + W(x) (C - R) over two control points, W(x) = (1 - s, s) with s = clamp(x_0, 0, 1):
// a displacement form whose rest state is the identity, as the lattices'.
class TableDeformer : public BoundDeformer {
 public:
  TableDeformer() : rest_{0, 0, 0, 1, 0, 0}, control_(rest_) {}
  void set_control(std::vector<double> c) { control_ = std::move(c); }
  void set_rest(std::vector<double> r) {
    rest_ = std::move(r);
    control_ = rest_;
  }
  bool is_identity() const override { return control_ == rest_; }
  std::uint64_t layout() const { return std::hash<std::string>()(std::string(reinterpret_cast<const char*>(rest_.data()),
                                                                             rest_.size() * sizeof(double))); }
  mutable int kernel_calls = 0;

  template <class T>
  TableBinding bind(const T* points, std::size_t n) const {
    TableBinding b;
    b.point_count = n;
    b.single_precision = std::is_same<T, float>::value;
    b.layout = layout();
    for (std::size_t i = 0; i < n; ++i) {
      const double s = std::clamp(double(points[3 * i]), 0.0, 1.0);
      b.weights.indices.insert(b.weights.indices.end(), {0, 1});
      b.weights.values.insert(b.weights.values.end(), {1.0 - s, s});
      b.weights.indptr.push_back(std::int64_t(b.weights.indices.size()));
    }
    if constexpr (std::is_same<T, float>::value) b.points_f.assign(points, points + 3 * n);
    else b.points_d.assign(points, points + 3 * n);
    return b;
  }

 protected:
  void check_binding(const PointBinding& binding) const override {
    const auto* b = dynamic_cast<const TableBinding*>(&binding);
    if (!b) throw std::invalid_argument("binding: was not made by a table deformer");
    if (b->layout != layout()) throw std::invalid_argument("binding: was made with another rest state");
  }
  template <class T>
  bool apply(const TableBinding& b, T* out) const {
    ++kernel_calls;
    std::vector<double> offset(control_.size());
    for (std::size_t i = 0; i < offset.size(); ++i) offset[i] = control_[i] - rest_[i];
    std::vector<double> moved(3 * b.size());
    apply_weight_table(b.weights, offset.data(), 3, moved.data());
    const T* x = points_of<T>(b);
    for (std::size_t i = 0; i < 3 * b.size(); ++i) out[i] = static_cast<T>(x[i] + moved[i]);
    return all_finite(out, b.size(), 3);
  }
  bool deform_bound_impl(const PointBinding& b, float* out) const override {
    return apply(static_cast<const TableBinding&>(b), out);
  }
  bool deform_bound_impl(const PointBinding& b, double* out) const override {
    return apply(static_cast<const TableBinding&>(b), out);
  }
  // Kept in point order, as an (n, 3) array.
  void bound_points(const PointBinding& b, StoredPoints<float>& points) const override {
    const float* p = static_cast<const TableBinding&>(b).points_f.data();
    points = StoredPoints<float>{{p, p + 1, p + 2}, 3, nullptr};
  }
  void bound_points(const PointBinding& b, StoredPoints<double>& points) const override {
    const double* p = static_cast<const TableBinding&>(b).points_d.data();
    points = StoredPoints<double>{{p, p + 1, p + 2}, 3, nullptr};
  }
  // Unbound: the same map point by point, without a table.
  template <class T>
  bool direct(const T* in, T* out, std::size_t n) const {
    for (std::size_t i = 0; i < n; ++i) {
      const double s = std::clamp(double(in[3 * i]), 0.0, 1.0);
      for (int a = 0; a < 3; ++a) {
        const double moved = (1.0 - s) * (control_[a] - rest_[a]) + s * (control_[3 + a] - rest_[3 + a]);
        out[3 * i + a] = static_cast<T>(in[3 * i + a] + moved);
      }
    }
    return all_finite(out, n, 3);
  }
  bool deform_impl(const float* in, float* out, std::size_t n) const override { return direct(in, out, n); }
  bool deform_impl(const double* in, double* out, std::size_t n) const override { return direct(in, out, n); }
  bool jacobian_impl(const double*, double* jac, std::size_t n) const override {
    identity_jacobians(jac, n);
    return false;
  }

 private:
  template <class T>
  static const T* points_of(const TableBinding& b) {
    if constexpr (std::is_same<T, float>::value) return b.points_f.data();
    else return b.points_d.data();
  }
  std::vector<double> rest_, control_;
};

}  // namespace

TEST(WeightTable, ProductMatchesTheDenseProduct) {
  for (std::size_t width : {1u, 3u, 5u}) {
    const std::size_t rows = 40000, columns = 9;  // above the parallel grain: several blocks
    const WeightTable w = random_table(rows, columns, unsigned(width));
    w.require_valid(columns, "weights");
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> control(columns, width);
    control.setRandom();
    const Eigen::MatrixXd expect = dense(w, columns) * control;
    std::vector<double> out(rows * width);
    std::vector<float> outf(rows * width);
    apply_weight_table(w, control.data(), width, out.data());
    apply_weight_table(w, control.data(), width, outf.data());
    for (std::size_t r = 0; r < rows; ++r)
      for (std::size_t c = 0; c < width; ++c) {
        ASSERT_NEAR(out[r * width + c], expect(Eigen::Index(r), Eigen::Index(c)), 1e-14) << r;
        ASSERT_EQ(outf[r * width + c], float(out[r * width + c])) << r;  // accumulated in double
      }
  }
}

TEST(WeightTable, MalformedTablesAreNamed) {
  WeightTable w;  // rows {0: 0.5, 3: 0.5}, {}, {2: 1}
  w.indptr = {0, 2, 2, 3};
  w.indices = {0, 3, 2};
  w.values = {0.5, 0.5, 1.0};
  w.require_valid(4, "table");
  expect_message([&] { w.require_valid(3, "table"); }, "table: column 3 is outside 0..3 - 1");
  WeightTable short_values = w;
  short_values.values.pop_back();
  expect_message([&] { short_values.require_valid(4, "table"); },
                 "table: indptr ends at 3 but there are 3 indices and 2 values");
  WeightTable decreasing = w;
  decreasing.indptr = {0, 2, 1, 3};
  expect_message([&] { decreasing.require_valid(4, "table"); }, "table: indptr decreases at row 1");
  WeightTable nan = w;
  nan.values[1] = std::nan("");
  expect_message([&] { nan.require_valid(4, "table"); }, "table: weight 1 is not finite");
  WeightTable offset = w;
  offset.indptr[0] = 1;
  expect_message([&] { offset.require_valid(4, "table"); }, "table: indptr must start at 0");
}

TEST(BoundDeformer, BoundEqualsUnboundBitForBit) {
  TableDeformer d;
  d.set_control({0.1, -0.2, 0.3, 1.4, 0.5, -0.6});
  const std::size_t n = 20000;
  const auto pts = random_points(n, -0.5, 1.5, 3);
  const std::vector<float> ptsf(pts.begin(), pts.end());
  std::vector<double> bound(3 * n), unbound(3 * n);
  std::vector<float> boundf(3 * n), unboundf(3 * n);
  d.deform_bound(d.bind(pts.data(), n), bound.data());
  d.deform(pts.data(), unbound.data(), n);
  d.deform_bound(d.bind(ptsf.data(), n), boundf.data());
  d.deform(ptsf.data(), unboundf.data(), n);
  EXPECT_EQ(bound, unbound);
  EXPECT_EQ(boundf, unboundf);
}

TEST(BoundDeformer, WeightsBlendTowardTheBoundPoints) {
  TableDeformer d;
  d.set_control({0.1, -0.2, 0.3, 1.4, 0.5, -0.6});
  const std::size_t n = 100;
  const auto pts = random_points(n, -0.5, 1.5, 4);
  std::vector<double> w(n);
  for (std::size_t i = 0; i < n; ++i) w[i] = double(i % 11) / 10.0;
  const TableBinding b = d.bind(pts.data(), n);
  std::vector<double> full(3 * n), blended(3 * n), through_deform(3 * n);
  d.deform_bound(b, full.data());
  d.set_weights(w);
  d.deform_bound(b, blended.data());
  d.deform(pts.data(), through_deform.data(), n);
  EXPECT_EQ(blended, through_deform);  // one blend for both paths
  for (std::size_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a)  // x + w (F(x) - x): w = 0 stays, w = 1 moves fully
      EXPECT_NEAR(blended[3 * i + a], pts[3 * i + a] + w[i] * (full[3 * i + a] - pts[3 * i + a]), 1e-15);
}

TEST(BoundDeformer, WeightCountMustMatchTheBinding) {
  TableDeformer d;
  d.set_control({0.1, -0.2, 0.3, 1.4, 0.5, -0.6});
  const auto pts = random_points(10, 0.0, 1.0, 5);
  const TableBinding b = d.bind(pts.data(), 10);
  d.set_weights(std::vector<double>(11, 0.5));
  std::vector<double> out(30);
  expect_message([&] { d.deform_bound(b, out.data()); }, "weights: has 11 entries but the binding has 10 points");
  EXPECT_EQ(d.kernel_calls, 0);  // refused before any work
}

TEST(BoundDeformer, AnOverflowIsTheDeformersReport) {
  TableDeformer d;
  const double big = std::numeric_limits<double>::max();
  d.set_control({big, 0, 0, 1.0 + big, 0, 0});  // C - R = DBL_MAX in x for both control points
  std::vector<double> pts = {0.5, 0, 0, 0.5, 0, 0, 1.0, 0, 0};
  pts[0] = -1.0;  // row 0: x + DBL_MAX is finite; row 1: 0.5 + DBL_MAX also rounds to DBL_MAX
  pts[6] = big;   // row 2: DBL_MAX + DBL_MAX overflows
  const TableBinding b = d.bind(pts.data(), 3);
  std::vector<double> out(9);
  expect_message([&] { d.deform_bound(b, out.data()); },
                 "deformer: row 2 maps to a non-finite position: the parameters overflow there");
}

TEST(BoundDeformer, IdentityReturnsTheBoundPointsExactly) {
  TableDeformer d;
  const std::vector<double> pts = {-0.0, 1e300, -1e-320, 0.25, -0.0, 3.0};
  const TableBinding b = d.bind(pts.data(), 2);
  d.set_weights({0.5, 0.25});
  std::vector<double> out(6, 7.0);
  d.deform_bound(b, out.data());
  for (std::size_t i = 0; i < 6; ++i) EXPECT_EQ(std::signbit(out[i]), std::signbit(pts[i])) << i;
  EXPECT_EQ(out, pts);
  EXPECT_EQ(d.kernel_calls, 0);
}

TEST(BoundDeformer, BindingsOfAnotherDtypeOrOwnerAreRefused) {
  TableDeformer d;
  const std::vector<float> ptsf = {0.5f, 0.0f, 0.0f};
  const TableBinding bf = d.bind(ptsf.data(), 1);
  std::vector<double> out(3);
  expect_message([&] { d.deform_bound(bf, out.data()); },
                 "binding: holds float32 points; deform them into an array of that dtype");
  const std::vector<double> pts = {0.5, 0.0, 0.0};
  const TableBinding bd = d.bind(pts.data(), 1);
  std::vector<float> outf(3);
  expect_message([&] { d.deform_bound(bd, outf.data()); },
                 "binding: holds float64 points; deform them into an array of that dtype");
  PointBinding foreign;
  foreign.point_count = 1;
  expect_message([&] { d.deform_bound(foreign, out.data()); }, "binding: was not made by a table deformer");
  d.set_rest({0, 0, 0, 2, 0, 0});  // the weights depend on the rest state: the binding is stale
  expect_message([&] { d.deform_bound(bd, out.data()); }, "binding: was made with another rest state");
}
