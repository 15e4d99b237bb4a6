#include "deformkit/lattice/box_lattice.hpp"

#include <stdexcept>
#include <string>

namespace deformkit {

namespace {

std::vector<double> rest_grid(const LatticeBox& box, const LatticeAxes& axes) {
  std::vector<double> grid;
  grid.reserve(3 * std::size_t(axes[0].count) * axes[1].count * axes[2].count);
  for (int i = 0; i < axes[0].count; ++i)
    for (int j = 0; j < axes[1].count; ++j)
      for (int k = 0; k < axes[2].count; ++k) {
        const Vec3 p =
            box.point(Vec3(axes[0].rest_coordinate(i), axes[1].rest_coordinate(j), axes[2].rest_coordinate(k)));
        grid.insert(grid.end(), {p[0], p[1], p[2]});
      }
  return grid;
}

LatticeAxes uniform_axes(BasisKind kind, std::array<int, 3> counts, const char* argument) {
  return {AxisBasis::make(kind, counts[0], argument), AxisBasis::make(kind, counts[1], argument),
          AxisBasis::make(kind, counts[2], argument)};
}

const LatticeAxes& checked(const LatticeAxes& axes, Outside outside, const char* counts_name) {
  // Each control point costs 48 bytes twice over; beyond this a typo, not a lattice.
  const double total = double(axes[0].count) * axes[1].count * axes[2].count;
  if (total > double(kMaxControlPoints))
    throw std::invalid_argument(std::string(counts_name) + ": " + std::to_string(static_cast<long long>(total)) +
                                " control points is more than the limit of " + std::to_string(kMaxControlPoints));
  if (outside == Outside::Extrapolate)
    for (const auto& a : axes)
      if (is_blender(a.kind))
        throw std::invalid_argument("outside: 'extrapolate' is not available for Blender lattices, which clamp "
                                    "(use 'clamp' or 'unchanged')");
  return axes;
}

}  // namespace

BoxLattice::BoxLattice(const LatticeBox& box, const LatticeAxes& axes, Outside outside, double strength,
                       const char* counts_name)
    : ControlLattice(axes, rest_grid(box, checked(axes, outside, counts_name)), outside, strength), box_(box) {
  set_affine_placement(box.to_box, box.origin);
}

PointStatus BoxLattice::locate(const Vec3& x, Vec3& parameters) const {
  parameters = box_.coordinates(x);
  for (int a = 0; a < 3; ++a)
    if (!axes()[a].locate(parameters[a], outside()).inside) return PointStatus::Outside;
  return PointStatus::Inside;
}

FFD::FFD(const LatticeBox& box, std::array<int, 3> degree, Outside outside, double strength)
    : BoxLattice(box, uniform_axes(BasisKind::Bernstein, {degree[0] + 1, degree[1] + 1, degree[2] + 1}, "degree"),
                 outside, strength, "degree") {}

BezierFFD::BezierFFD(const LatticeBox& box, std::array<int, 3> blocks, Outside outside, double strength)
    : BoxLattice(box, [&] {
        for (int b : blocks)
          if (b < 1 || b > 1024) throw std::invalid_argument("blocks: expected 1..1024 blocks per axis, got " + std::to_string(b));
        return uniform_axes(BasisKind::BezierBlocks, {3 * blocks[0] + 1, 3 * blocks[1] + 1, 3 * blocks[2] + 1},
                            "blocks");
      }(), outside, strength, "blocks") {}

BSplineLattice::BSplineLattice(const LatticeBox& box, std::array<int, 3> resolution, Outside outside,
                               double strength)
    : BoxLattice(box, uniform_axes(BasisKind::UniformBSpline, resolution, "resolution"), outside, strength,
                 "resolution") {}

BlenderLattice::BlenderLattice(const LatticeBox& box, std::array<int, 3> resolution,
                               std::array<BasisKind, 3> interpolation, Outside outside, double strength)
    : BoxLattice(box,
                 [&] {
                   for (BasisKind k : interpolation)
                     if (!is_blender(k)) throw std::invalid_argument("interpolation: not a Blender interpolation type");
                   return LatticeAxes{AxisBasis::make(interpolation[0], resolution[0], "resolution"),
                                      AxisBasis::make(interpolation[1], resolution[1], "resolution"),
                                      AxisBasis::make(interpolation[2], resolution[2], "resolution")};
                 }(),
                 outside, strength, "resolution") {}

}  // namespace deformkit
