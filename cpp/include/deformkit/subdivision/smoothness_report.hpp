#pragma once
// How smooth a limit surface is across the control mesh's edges (docs/math/subdivision.md, "Angles between normals").
#include "deformkit/core/deformer.hpp"
#include "deformkit/subdivision/limit_surface.hpp"

#include <vector>

namespace deformkit {

struct SmoothnessReport {
  std::vector<int> edges;           // interior edges as sorted vertex pairs (a < b)
  std::vector<double> edge_angle;   // max normal angle along each edge, radians
  std::vector<double> edge_gap;     // max position gap along each edge / bounding-box diagonal
  std::vector<int> worst_edges;     // indices into edges by decreasing angle
  double max_angle = 0.0, max_gap = 0.0;
  double min_regularity = 1.0;      // min |Du x Dv| / (|Du| |Dv|) over the samples
  long degenerate_samples = 0, flipped_samples = 0, sample_count = 0;
  std::vector<int> flipped_faces;
  int boundary_edges = 0;
  // With a deformer only: the normal jump inside each control face, the largest second
  // difference of the unit normal along a sample grid's lines, as an angle: O(h^2) where the
  // surface is smooth, about a crease's angle where one crosses. Faces by decreasing jump.
  std::vector<double> face_crease;
  std::vector<int> worst_faces;
  double max_crease = 0.0;
};

struct SmoothnessOptions {
  int samples_per_edge = 8;
  const double* reference = nullptr;  // rest points of the same topology, for flips
  int worst = 10;
  // Check F(S) instead of S: the limit surface of `points` mapped by the deformer, with tangents
  // J Du, J Dv and so normals cof(J) (Du x Dv) -- the surface a subdivide-then-deform order makes.
  const Deformer* deformer = nullptr;
  int crease_grid = 16;
};

// Samples t_k = (k + 1/2) / samples_per_edge along every interior edge on both faces' patches;
// the normal angle is atan2(|n1 x n2|, n1 . n2), exact near 0 where acos is not. A sample whose
// tangents are parallel (|Du x Dv| <= 1e-12 |Du| |Dv|) is degenerate and has no normal to compare.
// Flips (edge samples and face interiors): with a reference, a normal opposing the reference
// surface's normal at the same parameters turned by the best rotation of the face's neighbourhood
// from reference to points (so rigid motions, twists and bends flip nothing); without one, a normal
// opposing the control face's own (Newell) normal; with a deformer, det J < 0. Throws std::invalid_argument
// naming `samples_per_edge` outside 1..1000, `crease_grid` outside 1..64, `worst` below 0,
// `points` for non-finite or coincident points and `deformer` with per-point weights.
SmoothnessReport smoothness_report(const LimitSurface& surface, const double* points, const SmoothnessOptions& options);

}  // namespace deformkit
