#include "subdivision/osd_refiner.hpp"

#include <opensubdiv/far/topologyDescriptor.h>

#include <stdexcept>

namespace deformkit {

namespace {

using namespace OpenSubdiv;

Sdc::Options::FVarLinearInterpolation fvar_rule(UvSmooth s) {
  switch (s) {
    case UvSmooth::None: return Sdc::Options::FVAR_LINEAR_ALL;
    case UvSmooth::PreserveCorners: return Sdc::Options::FVAR_LINEAR_CORNERS_ONLY;
    case UvSmooth::PreserveCornersAndJunctions: return Sdc::Options::FVAR_LINEAR_CORNERS_PLUS1;
    case UvSmooth::PreserveCornersJunctionsAndConcave: return Sdc::Options::FVAR_LINEAR_CORNERS_PLUS2;
    case UvSmooth::PreserveBoundaries: return Sdc::Options::FVAR_LINEAR_BOUNDARIES;
    case UvSmooth::SmoothAll: return Sdc::Options::FVAR_LINEAR_NONE;
  }
  return Sdc::Options::FVAR_LINEAR_BOUNDARIES;
}

}  // namespace

std::unique_ptr<Refiner> make_refiner(const ControlMesh& mesh, bool with_uvs) {
  Far::TopologyDescriptor desc;
  desc.numVertices = int(mesh.vertex_count());
  desc.numFaces = int(mesh.face_count());
  std::vector<int> face_sizes(mesh.face_count());
  for (std::size_t f = 0; f < face_sizes.size(); ++f) face_sizes[f] = mesh.face_size(f);
  desc.numVertsPerFace = face_sizes.data();
  desc.vertIndicesPerFace = mesh.corners().data();
  std::vector<float> crease_weights(mesh.crease_sharpness.begin(), mesh.crease_sharpness.end());
  std::vector<int> corner_vertices;
  std::vector<float> corner_weights;
  const std::vector<double> sharpness = vertex_sharpness(mesh);
  for (std::size_t v = 0; v < sharpness.size(); ++v)
    if (sharpness[v] > 0) corner_vertices.push_back(int(v)), corner_weights.push_back(float(sharpness[v]));
  desc.numCreases = int(crease_weights.size());
  desc.creaseVertexIndexPairs = mesh.crease_edges.data();
  desc.creaseWeights = crease_weights.data();
  desc.numCorners = int(corner_weights.size());
  desc.cornerVertexIndices = corner_vertices.data();
  desc.cornerWeights = corner_weights.data();
  Far::TopologyDescriptor::FVarChannel channel;
  if (with_uvs && !mesh.uv_indices.empty()) {
    channel.numValues = int(mesh.uvs.size() / 2);
    channel.valueIndices = mesh.uv_indices.data();
    desc.numFVarChannels = 1;
    desc.fvarChannels = &channel;
  }
  Sdc::Options sdc;
  sdc.SetVtxBoundaryInterpolation(mesh.boundary == BoundaryRule::EdgeOnly ? Sdc::Options::VTX_BOUNDARY_EDGE_ONLY
                                                                          : Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
  sdc.SetFVarLinearInterpolation(fvar_rule(mesh.uv_smooth));
  const Sdc::SchemeType scheme = mesh.scheme == SubdivisionScheme::Loop ? Sdc::SCHEME_LOOP : Sdc::SCHEME_CATMARK;
  using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
  Factory::Options options(scheme, sdc);
  options.validateFullTopology = false;
  std::unique_ptr<Refiner> refiner(Factory::Create(desc, options));
  if (!refiner) throw std::invalid_argument("faces: OpenSubdiv rejected the mesh topology");
  return refiner;
}

}  // namespace deformkit
