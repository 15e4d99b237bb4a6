#pragma once
// One axis of a tensor-product lattice: which control points a coordinate touches, and how much.
#include <array>
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

bool is_blender(BasisKind kind);

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

  int pieces() const;
  int width() const;  // weights per point along this axis
  // The domain in normalised box coordinates s (0 and 1 are the box faces).
  double domain_lo() const;
  double domain_hi() const;
  // d(local t)/ds inside a piece.
  double scale() const;
  // Rest position of control point j in normalised box coordinates.
  double rest_coordinate(int j) const;

  AxisSpan locate(double s, Outside outside) const;
  // Weights and d/ds (frozen spans give 0) of the control points touched: index[0..width()).
  void evaluate(const AxisSpan& span, double* weight, double* derivative, int* index) const;
};

using LatticeAxes = std::array<AxisBasis, 3>;

}  // namespace deformkit
