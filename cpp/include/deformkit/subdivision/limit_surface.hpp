#pragma once
// The limit surface of a subdivision control mesh, evaluated at ptex (face, u, v) samples.
#include "deformkit/subdivision/control_mesh.hpp"

#include <memory>
#include <vector>

namespace deformkit {

// Samples of the limit surface; derivative arrays are empty when not asked for.
struct LimitSamples {
  std::vector<double> position, du, dv, normal, duu, duv, dvv;  // 3 per sample
};

// A ptex face and its (u, v): quads and Loop triangles are one ptex face each; a Catmull-Clark
// n-gon (n != 4) is n sub-quads, sub-quad k having (0, 0) at corner k, u towards the midpoint of
// edge k -> k + 1 and v towards the midpoint of edge k - 1 -> k.
// The control points of every patch for one cage, stored as points * 2^-exponent with the largest
// coordinate below 1 (a power of two is exact): evaluation then cannot overflow in its products and
// cross products whatever the cage's scale, and its results are scaled back exactly.
struct PatchPoints {
  std::vector<double> values;  // 3 per point
  int exponent = 0;
};

struct PtexPoint {
  int ptex;
  double u, v;
};

class LimitSurface {
 public:
  // Feature-adaptive OpenSubdiv patches in double precision with Gregory end caps at
  // extraordinary vertices; the topology is refined once and reused for any cage of it.
  explicit LimitSurface(ControlMesh mesh);
  ~LimitSurface();
  LimitSurface(const LimitSurface&) = delete;
  LimitSurface& operator=(const LimitSurface&) = delete;

  const ControlMesh& mesh() const { return mesh_; }
  int ptex_count() const { return ptex_offset_.back(); }
  // Base face f owns ptex faces ptex_offset()[f] .. ptex_offset()[f + 1] - 1.
  const std::vector<int>& ptex_offset() const { return ptex_offset_; }

  // The control points of every patch (refined vertices, then end-cap points) for one cage.
  // Throws std::invalid_argument naming `points` for non-finite points.
  PatchPoints patch_points(const double* points) const;

  // Throws std::invalid_argument naming `ptex` or `uv` for out-of-range samples.
  void check_samples(const int* ptex, const double* uv, std::size_t n) const;
  // derivatives: 0 = position, 1 = and du, dv, unit normal, 2 = and duu, duv, dvv. On both cores.
  // Subnormal u or v are taken as 0 (they are 0 to double precision). Throws std::invalid_argument
  // naming `points` where a result exceeds the double range (coordinates near 1e308).
  LimitSamples evaluate(const PatchPoints& patch_points, const int* ptex, const double* uv, std::size_t n,
                        int derivatives) const;

  // The point of base face `face`'s local edge `edge` (corner edge -> edge + 1) at t in [0, 1].
  PtexPoint edge_point(int face, int edge, double t) const;
  PtexPoint corner_point(int face, int corner) const;
  // A point inside base face `face` (its centre for quads and triangles; sub-quad k's centre for n-gons).
  PtexPoint interior_point(int face, int sub) const;

  // The limit position of every control vertex.
  std::vector<double> limit_points(const double* points) const;

 private:
  struct Osd;
  ControlMesh mesh_;
  std::vector<int> ptex_offset_, face_offset_;
  std::unique_ptr<Osd> osd_;
};

}  // namespace deformkit
