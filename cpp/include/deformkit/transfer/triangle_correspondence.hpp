#pragma once
// The correspondence phase of deformation transfer between unlike meshes (Sumner and Popovic 2004,
// section 5): the source is deformed towards the target under vertex markers, by the energy
// w_S E_S + w_I E_I + w_C E_C (deformation smoothness between adjacent triangles, closeness to the
// identity, closeness of each vertex to its closest valid point on the target), with w_C raised in
// steps; then source and target triangles whose centroids are close and whose normals agree are
// paired, searching from both sides so that every triangle gets a partner where one is near
// (docs/math/transfer.md, "Correspondence").
#include "deformkit/core/polygon_mesh.hpp"

#include <cstddef>
#include <vector>

namespace deformkit {

struct CorrespondenceOptions {
  double smoothness_weight = 1.0;  // w_S (Sumner and Popovic 2004, section 5)
  double identity_weight = 0.001;  // w_I
  // w_C for each step after the first (w_C = 0); lengths measured in units of the target's
  // bounding-box diagonal, so the weights do not depend on the meshes' scale.
  std::vector<double> closest_weights = {1.0, 17.1, 292.0, 5000.0};
  // Compatible triangles' centroids are at most this far apart (times the target's diagonal),
  // and never less than twice the longer mean edge length of the two meshes (a coarse mesh's
  // centroids are that far apart).
  double max_centroid_distance = 0.05;
};

struct TriangleCorrespondence {
  std::vector<int> pairs;              // m x 2: (source triangle, target triangle), each pair once
  std::vector<double> fitted_source;   // the source's points after the correspondence deformation
  double mean_distance = 0.0;          // of fitted_source's vertices to the target surface
  double max_distance = 0.0;
  std::vector<int> unmatched_target;   // target triangles with no source partner
  std::vector<int> unmatched_source;   // source triangles with no target partner
};

// source, target: triangle meshes (triangulate() others first); markers: source_markers[i] is
// placed on target_markers[i]. Throws std::invalid_argument naming markers for an index out of
// range, a source or target vertex given twice, or a connected part of the source without a
// marker (which part), and source_faces for a degenerate triangle.
TriangleCorrespondence triangle_correspondence(const PolygonMesh& source, const PolygonMesh& target,
                                               const std::vector<int>& source_markers,
                                               const std::vector<int>& target_markers,
                                               const CorrespondenceOptions& options = {});

}  // namespace deformkit
