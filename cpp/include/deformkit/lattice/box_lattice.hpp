#pragma once
// Lattices whose rest shape is the parallelepiped X0 + s S + t T + u U: Sederberg-Parry FFD,
// Bezier FFD blocks, the uniform cubic B-spline lattice and Blender's Lattice modifier.
#include "deformkit/lattice/control_lattice.hpp"
#include "deformkit/lattice/lattice_box.hpp"

namespace deformkit {

class BoxLattice : public ControlLattice {
 public:
  // Throws std::invalid_argument naming `resolution` for counts the bases cannot take, and
  // `outside` for Extrapolate with Blender's bases.
  // counts_name: the constructor argument that set the control-point counts, for errors.
  BoxLattice(const LatticeBox& box, const LatticeAxes& axes, Outside outside, double strength,
             const char* counts_name);
  const LatticeBox& box() const { return box_; }

 protected:
  PointStatus locate(const Vec3& x, Vec3& parameters) const override;
  Mat3 parameter_jacobian(const Vec3&) const override { return box_.to_box; }

 private:
  LatticeBox box_;
};

// Sederberg-Parry 1986: one trivariate Bernstein polynomial of degree (l, m, n).
class FFD : public BoxLattice {
 public:
  FFD(const LatticeBox& box, std::array<int, 3> degree, Outside outside = Outside::Clamp, double strength = 1.0);
};

// Piecewise tricubic Bezier "FFD blocks": (3a+1) x (3b+1) x (3c+1) control points.
class BezierFFD : public BoxLattice {
 public:
  BezierFFD(const LatticeBox& box, std::array<int, 3> blocks, Outside outside = Outside::Clamp,
            double strength = 1.0);
};

// Uniform cubic B-spline FFD (C2); rest control points span the box, the spline its inner part.
class BSplineLattice : public BoxLattice {
 public:
  BSplineLattice(const LatticeBox& box, std::array<int, 3> resolution, Outside outside = Outside::Clamp,
                 double strength = 1.0);
};

// Blender's Lattice modifier (lattice_deform.cc): per-axis interpolation, index clamping outside.
class BlenderLattice : public BoxLattice {
 public:
  BlenderLattice(const LatticeBox& box, std::array<int, 3> resolution, std::array<BasisKind, 3> interpolation,
                 Outside outside = Outside::Clamp, double strength = 1.0);
};

}  // namespace deformkit
