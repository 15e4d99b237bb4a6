#pragma once
// Coquillart's extended FFD (1990): a grid of tricubic Bezier blocks whose rest shape is not a
// parallelepiped; points are located by Newton iteration inside the block that contains them.
#include "deformkit/lattice/control_lattice.hpp"

#include <Eigen/Geometry>

namespace deformkit {

struct NewtonSettings {
  double tolerance = 1e-10;  // |X(s) - x| below tolerance * lattice size
  int max_iterations = 30;
};

class ExtendedFFD : public ControlLattice {
 public:
  // rest: grid (3a+1) x (3b+1) x (3c+1) x 3, C order. Control points that coincide at rest
  // (a cylinder's seam and axis) become one handle.
  ExtendedFFD(std::array<int, 3> counts, std::vector<double> rest, double strength, NewtonSettings newton);

  // Rest grid of a cylinder: s radial from the axis, t around it, u along it (Bezier arcs).
  static std::vector<double> cylinder_grid(double radius, double height, std::array<int, 3> blocks,
                                           const Vec3& center, int axis);

  // Rest grid of a triangular prism: s along A->B, t toward C (the edge through C is merged),
  // u along `height`.
  static std::vector<double> prism_grid(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& height,
                                        std::array<int, 3> blocks);

  const NewtonSettings& newton() const { return newton_; }
  double size() const { return size_; }

 protected:
  PointStatus locate(const Vec3& x, Vec3& parameters) const override;
  Mat3 parameter_jacobian(const Vec3& parameters) const override;

 private:
  enum class Placement { Inside, Outside, Failed };
  // Newton from (0.5, 0.5, 0.5), then from the 8 octant centres (docs/math/lattice.md, "Extended FFD").
  Placement invert_block(int block, const Vec3& x, Vec3& local) const;
  Vec3 block_point(int block, const Vec3& local, Mat3* derivative) const;
  void require_one_to_one() const;

  std::array<int, 3> blocks_{};
  std::vector<Eigen::AlignedBox3d> bounds_;  // control-point boxes: the convex hull test
  NewtonSettings newton_;
  double size_ = 1.0;
};

}  // namespace deformkit
