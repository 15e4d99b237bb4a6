#pragma once
// One axis of a tensor-product lattice: which control points a coordinate touches, and how much.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace deformkit {

enum class BasisKind : std::uint8_t {
  Bernstein,         // Sederberg-Parry: one polynomial of degree count-1 over the whole axis
  BezierBlocks,      // piecewise cubic Bezier, (count-1)/3 blocks sharing end layers
  UniformBSpline,    // uniform cubic B-spline, count-3 spans over the inner part of the box
  BlenderLinear,     // Blender's lattice (key_curve_position_weights), with its index clamping
  BlenderCardinal,
  BlenderCatmullRom,
  BlenderBSpline,
};

// What happens to a coordinate outside the basis' domain.
enum class Outside : std::uint8_t {
  Clamp,        // clamp to the domain: the boundary's displacement carries on (Blender: edge repeat)
  Unchanged,    // no displacement outside the box
  Extrapolate,  // the end pieces' polynomials continued
};

constexpr int kMaxAxisWidth = 16;  // Bernstein degree <= 15
constexpr int kMaxBlenderResolution = 64;
constexpr long kMaxControlPoints = 1L << 22;

inline bool is_blender(BasisKind kind) {
  return kind == BasisKind::BlenderLinear || kind == BasisKind::BlenderCardinal ||
         kind == BasisKind::BlenderCatmullRom || kind == BasisKind::BlenderBSpline;
}

// Bernstein polynomials B_i^d(t) = C(d,i) t^i (1-t)^(d-i), i = 0..d, and d/dt (Sederberg-Parry 1986 eq. 1).
void bernstein_basis(int degree, double t, double* value, double* derivative);

// Blender's key_curve_position_weights for the four lattice interpolation types, and d/dt.
void blender_key_weights(BasisKind kind, double t, double value[4], double derivative[4]);

// Where a coordinate falls along an axis.
struct AxisSpan {
  std::int32_t piece = 0;  // block / span / cell index (Blender: floor of the grid coordinate)
  double t = 0.0;          // local coordinate within the piece
  bool inside = true;      // inside the domain
  bool frozen = false;     // clamped: the map does not vary with this coordinate here
};

struct AxisBasis {
  BasisKind kind = BasisKind::Bernstein;
  int count = 2;  // control points along the axis

  // Throws std::invalid_argument naming `argument` when count does not suit the kind.
  static AxisBasis make(BasisKind kind, int count, const char* argument);

  // Cached by make(): locate runs per point and coordinate, and divisions are slow.
  int pieces() const { return pieces_; }
  int width() const { return kind == BasisKind::Bernstein ? count : 4; }  // weights per point along this axis
  // The domain in normalised box coordinates s (0 and 1 are the box faces).
  double domain_lo() const { return lo_; }
  double domain_hi() const { return hi_; }
  // d(local t)/ds inside a piece.
  double scale() const { return scale_; }
  // Rest position of control point j in normalised box coordinates.
  double rest_coordinate(int j) const { return count == 1 ? 0.5 : double(j) / (count - 1); }

  AxisSpan locate(double s, Outside outside) const;

  int pieces_ = 1;
  double lo_ = 0.0, hi_ = 1.0, scale_ = 1.0;
  // Weights and d/ds (frozen spans give 0) of the control points touched: index[0..width()).
  void evaluate(const AxisSpan& span, double* weight, double* derivative, int* index) const;
};

// floor for |x| < 2^31 without a call into libm (baseline x86-64 has no rounding instruction).
inline int floor_int(double x) {
  const int i = static_cast<int>(x);
  return i - (x < i);
}

inline AxisSpan AxisBasis::locate(double s, Outside outside) const {
  AxisSpan span;
  constexpr double kSlack = 1e-12;  // rest points on a face must count as inside despite rounding
  const double lo = domain_lo(), hi = domain_hi();
  span.inside = s >= lo - kSlack && s <= hi + kSlack;
  if (is_blender(kind)) {
    if (count == 1) {
      span.frozen = true;
      return span;
    }
    // lattice_deform.cc: i = floor(s (n-1)); indices i-1..i+2 clamped (edge repeat). Beyond two
    // cells all four clamp to the same point, so g is limited first without changing the result.
    const double g = std::clamp(s * (count - 1), -3.0, count + 1.0);
    const int i = floor_int(g);
    span.t = g - i;
    span.piece = std::clamp(i, -2, count);
    span.frozen = i <= -2 || i >= count;
    return span;
  }
  double c = s;
  if (outside != Outside::Extrapolate && !span.inside) {
    c = std::clamp(s, lo, hi);
    span.frozen = true;
  }
  const double g = (c - lo) * scale();
  span.piece = g <= 0.0 ? 0 : g >= pieces() - 1 ? pieces() - 1 : floor_int(g);
  span.t = g - span.piece;
  return span;
}

using LatticeAxes = std::array<AxisBasis, 3>;

}  // namespace deformkit
