// Python bindings of subdivision, limit-surface evaluation and the smoothness report.
#include "common.hpp"
#include "declared.hpp"

#include "deformkit/subdivision/blender_order.hpp"
#include "deformkit/subdivision/limit_surface.hpp"
#include "deformkit/subdivision/smoothness_report.hpp"
#include "deformkit/subdivision/subdivide.hpp"

#include <limits>
#include <memory>
#include <optional>

namespace deformkit_py {

using namespace pybind11::literals;

namespace {

std::vector<std::int64_t> int_rows(const py::object& obj, const char* name, py::ssize_t columns) {
  return parse_index_array(obj, name, "integer vertex indices", [&](const py::array& a) {
    const bool ok = columns == 1 ? a.ndim() == 1 : (a.ndim() == 2 && a.shape(1) == columns) || a.size() == 0;
    if (!ok)
      throw py::value_error(std::string(name) + ": expected shape " + (columns == 1 ? "(k,)" : "(k, 2)") + ", got " +
                            shape_of(a));
  });
}

std::vector<double> real_vector(const py::object& obj, const char* name) {
  const auto v = real_array(obj, name);
  if (v.ndim() != 1) throw py::value_error(std::string(name) + ": expected a 1-D sequence of sharpness values");
  return {v.data(), v.data() + v.size()};
}

std::pair<py::object, py::object> pair_of(const py::object& obj, const char* name, const char* what) {
  if (!py::isinstance<py::tuple>(obj) && !py::isinstance<py::list>(obj))
    throw py::type_error(std::string(name) + ": expected a pair (" + what + ", sharpness)");
  const py::sequence s = py::reinterpret_borrow<py::sequence>(obj);
  if (s.size() != 2) throw py::value_error(std::string(name) + ": expected a pair (" + what + ", sharpness)");
  return {s[0], s[1]};
}

// 'auto' is decided by the mesh (Loop when every face is a triangle).
const EnumNames<std::optional<SubdivisionScheme>> kSchemeNames("scheme", {{"auto", std::nullopt},
                                                                          {"catmull_clark", SubdivisionScheme::CatmullClark},
                                                                          {"loop", SubdivisionScheme::Loop}});
const EnumNames<BoundaryRule> kBoundaryNames("boundary", {{"edge_and_corner", BoundaryRule::EdgeAndCorner},
                                                          {"edge_only", BoundaryRule::EdgeOnly}});
const EnumNames<UvSmooth> kUvSmoothNames(
    "uv_smooth", {{"none", UvSmooth::None},
                  {"preserve_corners", UvSmooth::PreserveCorners},
                  {"preserve_corners_and_junctions", UvSmooth::PreserveCornersAndJunctions},
                  {"preserve_corners_junctions_and_concave", UvSmooth::PreserveCornersJunctionsAndConcave},
                  {"preserve_boundaries", UvSmooth::PreserveBoundaries},
                  {"smooth_all", UvSmooth::SmoothAll}});

std::optional<SubdivisionScheme> parse_scheme(const std::string& s) { return kSchemeNames.parse(s); }

BoundaryRule parse_boundary(const std::string& s) { return kBoundaryNames.parse(s); }

UvSmooth parse_uv_smooth(const std::string& s) { return kUvSmoothNames.parse(s); }

// The control mesh keeps a copy of the cage's points (the caller may change them afterwards): the
// default cage of every call that takes points=.
ControlMesh parse_cage(const py::object& points, const py::object& faces, const std::string& scheme,
                       const std::string& boundary, const py::object& creases, const py::object& corners,
                       bool sharpen_two_edge_vertices) {
  PolygonMesh polygons = parse_polygon_mesh(points, faces);
  const std::optional<SubdivisionScheme> named = parse_scheme(scheme);
  const SubdivisionScheme resolved =
      named ? *named : polygons.all_triangles() ? SubdivisionScheme::Loop : SubdivisionScheme::CatmullClark;
  ControlMesh mesh = make_control_mesh(std::move(polygons), resolved, parse_boundary(boundary));
  mesh.sharpen_two_edge_vertices = sharpen_two_edge_vertices;
  if (!creases.is_none()) {
    const auto [edges, sharpness] = pair_of(creases, "creases", "edges (k, 2)");
    set_creases(mesh, int_rows(edges, "creases", 2), real_vector(sharpness, "creases"));
  }
  if (!corners.is_none()) {
    const auto [vertices, sharpness] = pair_of(corners, "corners", "vertices (c,)");
    set_corners(mesh, int_rows(vertices, "corners", 1), real_vector(sharpness, "corners"));
  }
  return mesh;
}

// A cage for an existing topology: `points` (n, 3) of the same vertex count.
py::array_t<double, py::array::c_style> same_cage(const py::object& points, std::size_t n, const char* name) {
  auto p = as_double(points_array(points, name), name);
  if (std::size_t(p.shape(0)) != n)
    throw py::value_error(std::string(name) + ": expected " + std::to_string(n) + " rows (the control mesh's vertices), got " +
                          std::to_string(p.shape(0)));
  return p;
}

// The cage a call works on: `points` when given (checked against the control mesh), else the
// control mesh's own. `given` keeps a converted array alive.
const double* cage_or_default(const py::object& points, const ControlMesh& mesh,
                              py::array_t<double, py::array::c_style>& given) {
  if (points.is_none()) return mesh.polygons.points().data();
  given = same_cage(points, mesh.vertex_count(), "points");
  return given.data();
}

struct PySubdividedMesh {
  py::array points, faces, face_origin;
  py::object uvs;
  int level;
  std::string scheme;
};

struct PyLimitSurface {
  std::shared_ptr<LimitSurface> surface;
  std::shared_ptr<PatchPoints> patch_points;  // of the cage given at construction
};

// A 1-D numpy copy (the report keeps its own).
template <class T>
py::array_t<T> copy_of(const std::vector<T>& v) {
  return copied_array(v.data(), {py::ssize_t(v.size())});
}

py::dict samples_dict(LimitSamples&& s, py::ssize_t n) {
  py::dict d;
  const std::pair<const char*, std::vector<double>*> fields[] = {
      {"position", &s.position}, {"du", &s.du}, {"dv", &s.dv}, {"normal", &s.normal},
      {"duu", &s.duu}, {"duv", &s.duv}, {"dvv", &s.dvv}};
  for (const auto& [name, v] : fields)
    if (!v->empty()) d[name] = owned_array(std::move(*v), {n, 3});
  return d;
}

py::object report_object(SmoothnessReport&& r);

std::shared_ptr<Deformer> parse_deformer(const py::object& deformer) {
  if (deformer.is_none()) return nullptr;
  try {
    return deformer.cast<std::shared_ptr<Deformer>>();
  } catch (const py::cast_error&) {
    throw py::type_error("deformer: expected a deformkit deformer (Twist, Bend, FFD, Stack, ...), got " +
                         std::string(py::str(py::type::of(deformer).attr("__name__"))));
  }
}

SmoothnessOptions options(std::int64_t samples_per_edge, const double* reference, std::int64_t worst,
                          const Deformer* deformer, std::int64_t crease_grid) {
  SmoothnessOptions o;
  o.samples_per_edge = int_arg(samples_per_edge, "samples_per_edge", 1, 1000);
  o.reference = reference;
  o.worst = int_arg(worst, "worst", 0, std::numeric_limits<int>::max());
  o.deformer = deformer;
  o.crease_grid = int_arg(crease_grid, "crease_grid", 1, 64);
  return o;
}

const char* kSubdivideDoc = R"(

uvs: one (u, v) per face corner in the order of faces (Blender's loop UVs); corners of one vertex
with equal UVs are welded, seams stay seams. uv_smooth takes Blender's UV Smooth names: 'none',
'preserve_corners', 'preserve_corners_and_junctions', 'preserve_corners_junctions_and_concave',
'preserve_boundaries' (default) or 'smooth_all'. A level whose output would have more than
max_faces faces (default SUBDIVISION_MAX_FACES = 2**24) is refused before any work.
limit_surface=True (Blender's "Use Limit Surface") gives the limit surface at every refined vertex
(LimitSurface at its exact ptex parameters) instead of the refined points.)";

ControlMesh cage_with_uvs(const py::object& points, const py::object& faces, const std::string& scheme,
                          const std::string& boundary, const py::object& creases, const py::object& corners,
                          bool sharpen_two_edge_vertices, const py::object& uvs, const std::string& uv_smooth,
                          std::int64_t max_faces) {
  ControlMesh cage = parse_cage(points, faces, scheme, boundary, creases, corners, sharpen_two_edge_vertices);
  if (max_faces < 1) throw py::value_error("max_faces: must be >= 1, got " + std::to_string(max_faces));
  const UvSmooth smooth = parse_uv_smooth(uv_smooth);
  if (uvs.is_none()) return cage;
  const auto d = real_array(uvs, "uvs");
  if (d.ndim() != 2 || d.shape(1) != 2) throw py::value_error("uvs: expected shape (corners, 2), got " + shape_of(d));
  set_uvs(cage, d.data(), std::size_t(d.shape(0)), smooth);
  return cage;
}

PySubdividedMesh to_python(SubdividedMesh&& out) {
  PySubdividedMesh r;
  const auto faces_n = py::ssize_t(out.face_origin.size()), k = py::ssize_t(out.corners_per_face);
  r.points = owned_array(std::move(out.points), {py::ssize_t(out.points.size() / 3), 3});
  r.faces = owned_array(std::move(out.faces), {faces_n, k});
  r.face_origin = owned_array(std::move(out.face_origin), {faces_n});
  r.uvs = out.uvs.empty() ? py::object(py::none()) : py::object(owned_array(std::move(out.uvs), {faces_n * k, 2}));
  r.level = out.level;
  r.scheme = scheme_name(out.scheme);
  return r;
}

struct PySubdivider {
  std::shared_ptr<Subdivider> subdivider;
};

PySubdivider make_subdivider(const py::object& points, const py::object& faces, std::int64_t level_arg, const std::string& scheme,
                             const std::string& boundary, const py::object& creases, const py::object& corners,
                             const py::object& sharpen_two_edge_vertices, const py::object& uvs,
                             const std::string& uv_smooth, std::int64_t max_faces, const py::object& limit_surface_arg) {
  const int level = int_arg(level_arg, "level", 1, kMaxSubdivisionLevel);
  const bool limit_surface = bool_arg(limit_surface_arg, "limit_surface");
  ControlMesh cage = cage_with_uvs(points, faces, scheme, boundary, creases, corners,
                                   bool_arg(sharpen_two_edge_vertices, "sharpen_two_edge_vertices"), uvs, uv_smooth,
                                   max_faces);
  PySubdivider s;
  py::gil_scoped_release release;
  s.subdivider = std::make_shared<Subdivider>(std::move(cage), level, max_faces, limit_surface);
  return s;
}

const char* kTopologyDoc = R"(scheme 'auto' (Loop when every face is a triangle, else Catmull-Clark), 'catmull_clark' or
'loop'; boundary 'edge_and_corner' (boundary edges are B-spline curves and corners of valence 2
stay put: Blender's Keep Corners) or 'edge_only' (Blender's Smooth); creases (edges (k, 2),
sharpness (k,)) and corners (vertices (c,), sharpness (c,)) in OpenSubdiv's units, 10 or more
being infinitely sharp. sharpen_two_edge_vertices (default True, as Blender's OpenSubdiv topology
code does) gives every vertex with exactly two edges the smaller of their sharpnesses on top of its
own (at most 10): a plane whose border edges are creased keeps its corners, as in Blender; False
gives OpenSubdiv's plain rules. faces must form a manifold: every vertex in a face, at most two
faces on an edge, consistently wound.)";

}  // namespace

void bind_subdivision(py::module_& m) {
  m.attr("SUBDIVISION_MAX_LEVEL") = kMaxSubdivisionLevel;
  m.attr("SUBDIVISION_MAX_FACES") = kDefaultMaxFaces;

  Class<PySubdividedMesh>(m, "SubdividedMesh", "The result of subdivide().")
      .def_readonly("points", &PySubdividedMesh::points,
                    "(N, 3) float64 refined vertices (on the limit surface with limit_surface=True).")
      .def_readonly("faces", &PySubdividedMesh::faces, "(M, 4) int32 quads (Catmull-Clark) or (M, 3) triangles (Loop).")
      .def_readonly("face_origin", &PySubdividedMesh::face_origin, "(M,) int32: the control face each face comes from.")
      .def_readonly("uvs", &PySubdividedMesh::uvs, "(M * k, 2) float64 per face corner, or None.")
      .def_readonly("level", &PySubdividedMesh::level)
      .def_readonly("scheme", &PySubdividedMesh::scheme)
      .def("__repr__", [](const PySubdividedMesh& s) {
        return "<SubdividedMesh " + s.scheme + " level " + std::to_string(s.level) + ": " +
               std::to_string(s.points.shape(0)) + " points, " + std::to_string(s.faces.shape(0)) + " faces>";
      });

  Class<PySubdivider>(m, "Subdivider", (std::string(R"(The refined topology of a control mesh at one level, kept to subdivide many cages of it
(animation frames, deformations): subdivide(points) only interpolates the points again.

)") + kTopologyDoc + kSubdivideDoc).c_str())
      .def(py::init(&make_subdivider), "points"_a, "faces"_a, "level"_a, py::kw_only(), "scheme"_a = "auto",
           "boundary"_a = "edge_and_corner", "creases"_a = py::none(), "corners"_a = py::none(),
           "sharpen_two_edge_vertices"_a = true, "uvs"_a = py::none(), "uv_smooth"_a = "preserve_boundaries",
           "max_faces"_a = kDefaultMaxFaces, "limit_surface"_a = false)
      .def("subdivide", [](const PySubdivider& s, const py::object& points) {
        py::array_t<double, py::array::c_style> given;
        const double* cage = cage_or_default(points, s.subdivider->control(), given);
        std::vector<double> out;
        {
          py::gil_scoped_release release;
          out = s.subdivider->subdivide(cage);
        }
        return owned_array(std::move(out), {py::ssize_t(s.subdivider->vertex_count()), 3});
      }, "points"_a = py::none(), "The refined points (N, 3) of this cage (the one given at construction by default).")
      .def("mesh", [](const PySubdivider& s, const py::object& points) {
        py::array_t<double, py::array::c_style> given;
        const double* cage = cage_or_default(points, s.subdivider->control(), given);
        SubdividedMesh out;
        {
          py::gil_scoped_release release;
          out = s.subdivider->mesh(cage);
        }
        return to_python(std::move(out));
      }, "points"_a = py::none(), "The SubdividedMesh of this cage.")
      .def_property_readonly("vertex_count", [](const PySubdivider& s) { return s.subdivider->vertex_count(); })
      .def_property_readonly("level", [](const PySubdivider& s) { return s.subdivider->level(); })
      .def_property_readonly("scheme", [](const PySubdivider& s) { return scheme_name(s.subdivider->control().scheme); })
      .def_property_readonly("faces", [](const PySubdivider& s) {
        std::vector<int> f = s.subdivider->faces();
        const auto k = py::ssize_t(s.subdivider->corners_per_face()), n = py::ssize_t(f.size()) / k;
        return owned_array(std::move(f), {n, k});
      })
      .def_property_readonly("face_origin", [](const PySubdivider& s) {
        std::vector<int> f = s.subdivider->face_origin();
        const auto n = py::ssize_t(f.size());
        return owned_array(std::move(f), {n});
      })
      .def_property_readonly("limit_surface", [](const PySubdivider& s) { return s.subdivider->limit_surface(); })
      .def("vertex_parameters", [](const PySubdivider& s) {
        const std::vector<PtexPoint> params = s.subdivider->vertex_parameters();
        std::vector<int> ptex(params.size());
        std::vector<double> uv(2 * params.size());
        for (std::size_t i = 0; i < params.size(); ++i) ptex[i] = params[i].ptex, uv[2 * i] = params[i].u, uv[2 * i + 1] = params[i].v;
        const auto n = py::ssize_t(params.size());
        return py::make_tuple(owned_array(std::move(ptex), {n}), owned_array(std::move(uv), {n, 2}));
      }, "(ptex (N,), uv (N, 2)): where each refined vertex lies on LimitSurface(points, faces) of the same settings.")
      .def("blender_order", [](const PySubdivider& s, const py::object& edges_arg) {
        const std::vector<std::int64_t> wide = int_rows(edges_arg, "edges", 2);
        std::vector<int> edges(wide.size());
        for (std::size_t i = 0; i < wide.size(); ++i) {
          if (wide[i] < 0 || wide[i] > std::numeric_limits<int>::max())
            throw py::value_error("edges: vertex index " + std::to_string(wide[i]) + " is out of range");
          edges[i] = int(wide[i]);
        }
        BlenderOrder order;
        {
          py::gil_scoped_release release;
          order = blender_order(*s.subdivider, edges.data(), edges.size() / 2);
        }
        const auto nv = py::ssize_t(order.vertex.size()), nf = py::ssize_t(order.face.size());
        const auto ne = py::ssize_t(order.edges.size() / 2);
        return py::make_tuple(owned_array(std::move(order.vertex), {nv}), owned_array(std::move(order.face), {nf}),
                              owned_array(std::move(order.face_start), {nf}),
                              owned_array(std::move(order.edges), {ne, 2}));
      }, "edges"_a, R"((vertex (N,), face (M,), face_start (M,), edges (K, 2)), int32: how Blender's Subdivision
Surface modifier numbers this Catmull-Clark subdivision. vertex[i] and face[f] are the indices
Blender gives refined vertex i and face f, corner face_start[f] of face f is Blender's first
corner, and edges are Blender's edges in its order and vertex numbering. edges (E, 2): the
control mesh's edges as Blender numbers and orients them (mesh.edges[i].vertices), exactly the
edges of its faces (no loose edges).)");

  def(m, "subdivide", [](const py::object& points, const py::object& faces, std::int64_t level_arg,
                        const std::string& scheme, const std::string& boundary, const py::object& creases,
                        const py::object& corners, const py::object& sharpen_two_edge_vertices, const py::object& uvs,
                        const std::string& uv_smooth, std::int64_t max_faces, const py::object& limit_surface_arg) {
    const int level = int_arg(level_arg, "level", 1, kMaxSubdivisionLevel);
    const bool limit_surface = bool_arg(limit_surface_arg, "limit_surface");
    const ControlMesh cage = cage_with_uvs(points, faces, scheme, boundary, creases, corners,
                                           bool_arg(sharpen_two_edge_vertices, "sharpen_two_edge_vertices"), uvs,
                                           uv_smooth, max_faces);
    SubdividedMesh out;
    {
      py::gil_scoped_release release;
      out = subdivide(cage, cage.polygons.points().data(), level, max_faces, limit_surface);
    }
    return to_python(std::move(out));
  }, "points"_a, "faces"_a, "level"_a, py::kw_only(), "scheme"_a = "auto", "boundary"_a = "edge_and_corner",
     "creases"_a = py::none(), "corners"_a = py::none(), "sharpen_two_edge_vertices"_a = true, "uvs"_a = py::none(),
     "uv_smooth"_a = "preserve_boundaries", "max_faces"_a = kDefaultMaxFaces, "limit_surface"_a = false,
     (std::string(R"(Uniform subdivision with OpenSubdiv to level 1..SUBDIVISION_MAX_LEVEL (8); Subdivider keeps
the refined topology for many cages.

)") + kTopologyDoc + kSubdivideDoc).c_str());

  Class<PyLimitSurface>(m, "LimitSurface", (std::string(R"(The limit surface of a control mesh (OpenSubdiv feature-adaptive patches in double precision:
exact B-spline patches, and Gregory patches approximating it within 2^-4 of extraordinary
vertices, whose derivatives are OpenSubdiv's approximate ones).

)") + kTopologyDoc + R"(

Samples are ptex faces with (u, v): a quad (Catmull-Clark) or a triangle (Loop) is one ptex face
(quad corners at (0,0), (1,0), (1,1), (0,1); triangle corners at (0,0), (1,0), (0,1)); an n-gon
(n != 4) is n sub-quads, sub-quad k with (0, 0) at corner k, u towards the midpoint of edge
k -> k+1, v towards that of edge k-1 -> k. Face f owns ptex faces ptex_offset[f] ..
ptex_offset[f+1] - 1.)").c_str())
      .def(py::init([](const py::object& points, const py::object& faces, const std::string& scheme,
                       const std::string& boundary, const py::object& creases, const py::object& corners,
                       const py::object& sharpen_two_edge_vertices) {
             ControlMesh cage = parse_cage(points, faces, scheme, boundary, creases, corners,
                                           bool_arg(sharpen_two_edge_vertices, "sharpen_two_edge_vertices"));
             PyLimitSurface s;
             {
               py::gil_scoped_release release;
               s.surface = std::make_shared<LimitSurface>(std::move(cage));
               s.patch_points =
                   std::make_shared<PatchPoints>(s.surface->patch_points(s.surface->mesh().polygons.points().data()));
             }
             return s;
           }),
           "points"_a, "faces"_a, py::kw_only(), "scheme"_a = "auto", "boundary"_a = "edge_and_corner",
           "creases"_a = py::none(), "corners"_a = py::none(), "sharpen_two_edge_vertices"_a = true)
      .def_property_readonly("ptex_count", [](const PyLimitSurface& s) { return s.surface->ptex_count(); })
      .def_property_readonly("ptex_offset", [](const PyLimitSurface& s) {
        std::vector<int> o = s.surface->ptex_offset();
        const auto n = py::ssize_t(o.size());
        return owned_array(std::move(o), {n});
      })
      .def_property_readonly("vertex_count", [](const PyLimitSurface& s) { return s.surface->mesh().vertex_count(); })
      .def_property_readonly("scheme", [](const PyLimitSurface& s) { return scheme_name(s.surface->mesh().scheme); })
      .def("evaluate", [](const PyLimitSurface& s, const py::object& ptex, const py::object& uv,
                          const py::object& points, std::int64_t derivatives_arg) {
        const int derivatives = int_arg(derivatives_arg, "derivatives", 0, 2);
        const std::vector<std::int64_t> faces = int_rows(ptex, "ptex", 1);
        const auto uvd = real_array(uv, "uv");
        if (uvd.ndim() != 2 || uvd.shape(1) != 2 || std::size_t(uvd.shape(0)) != faces.size())
          throw py::value_error("uv: expected shape (" + std::to_string(faces.size()) + ", 2), one row per ptex sample, got " +
                                shape_of(uvd));
        std::vector<int> f32(faces.size());
        for (std::size_t i = 0; i < faces.size(); ++i) {
          if (faces[i] < 0 || faces[i] >= s.surface->ptex_count())
            throw py::value_error("ptex: sample " + std::to_string(i) + " has ptex face " + std::to_string(faces[i]) +
                                  ", outside 0.." + std::to_string(s.surface->ptex_count() - 1));
          f32[i] = int(faces[i]);
        }
        std::shared_ptr<PatchPoints> cvs = s.patch_points;
        py::array_t<double, py::array::c_style> cage;
        if (!points.is_none()) cage = same_cage(points, s.surface->mesh().vertex_count(), "points");
        LimitSamples out;
        {
          py::gil_scoped_release release;
          s.surface->check_samples(f32.data(), uvd.data(), f32.size());
          if (!points.is_none()) cvs = std::make_shared<PatchPoints>(s.surface->patch_points(cage.data()));
          out = s.surface->evaluate(*cvs, f32.data(), uvd.data(), f32.size(), derivatives);
        }
        return samples_dict(std::move(out), py::ssize_t(f32.size()));
      }, "ptex"_a, "uv"_a, py::kw_only(), "points"_a = py::none(), "derivatives"_a = 1,
         R"(The limit surface at samples ptex (s,) and uv (s, 2): a dict of (s, 3) arrays, "position", and
with derivatives >= 1 "du", "dv" and the unit "normal" (du x dv normalised; zero where du x dv
vanishes), with derivatives = 2 also "duu", "duv", "dvv". points= evaluates another cage of the
same topology (a deformed one) without rebuilding the patches.)")
      .def("limit_points", [](const PyLimitSurface& s, const py::object& points) {
        py::array_t<double, py::array::c_style> given;
        const double* cage = cage_or_default(points, s.surface->mesh(), given);
        std::vector<double> out;
        {
          py::gil_scoped_release release;
          out = s.surface->limit_points(cage);
        }
        return owned_array(std::move(out), {py::ssize_t(s.surface->mesh().vertex_count()), 3});
      }, "points"_a = py::none(), "The limit position of every control vertex, (n, 3).")
      .def("smoothness_report", [](const PyLimitSurface& s, const py::object& points, std::int64_t samples_per_edge,
                                   const py::object& reference, std::int64_t worst, const py::object& deformer,
                                   std::int64_t crease_grid) {
        py::array_t<double, py::array::c_style> given, ref;
        const double* cage = cage_or_default(points, s.surface->mesh(), given);
        if (!reference.is_none()) ref = same_cage(reference, s.surface->mesh().vertex_count(), "reference");
        const std::shared_ptr<Deformer> map = parse_deformer(deformer);
        SmoothnessReport r;
        {
          py::gil_scoped_release release;
          r = smoothness_report(*s.surface, cage,
                                options(samples_per_edge, reference.is_none() ? nullptr : ref.data(), worst, map.get(),
                                        crease_grid));
        }
        return report_object(std::move(r));
      }, "points"_a = py::none(), py::kw_only(), "samples_per_edge"_a = 8, "reference"_a = py::none(),
         "worst"_a = 10, "deformer"_a = py::none(), "crease_grid"_a = 16, "The smoothness report (see deformkit.smoothness_report) of this surface or of another cage of it.");

  Class<SmoothnessReport>(m, "SmoothnessReport", R"(How smooth a limit surface is across the control mesh's interior edges.

edges (E, 2) are the interior edges as sorted vertex pairs; edge_angle the largest normal angle
along each (radians, atan2(|n1 x n2|, n1 . n2)); edge_gap the largest position gap divided by
the bounding-box diagonal; worst_edges indices into edges by decreasing angle.)")
      .def_readonly("max_angle", &SmoothnessReport::max_angle)
      .def_readonly("max_gap", &SmoothnessReport::max_gap)
      .def_readonly("min_regularity", &SmoothnessReport::min_regularity,
                    "Smallest |du x dv| / (|du| |dv|) over the samples: 0 where the tangents are parallel.")
      .def_readonly("degenerate_samples", &SmoothnessReport::degenerate_samples)
      .def_readonly("flipped_samples", &SmoothnessReport::flipped_samples)
      .def_readonly("sample_count", &SmoothnessReport::sample_count)
      .def_readonly("boundary_edges", &SmoothnessReport::boundary_edges)
      .def_property_readonly("edges", [](const SmoothnessReport& r) {
        std::vector<int> e = r.edges;
        const auto n = py::ssize_t(e.size() / 2);
        return owned_array(std::move(e), {n, 2});
      })
      .def_property_readonly("edge_angle", [](const SmoothnessReport& r) { return copy_of(r.edge_angle); })
      .def_property_readonly("edge_gap", [](const SmoothnessReport& r) { return copy_of(r.edge_gap); })
      .def_property_readonly("worst_edges", [](const SmoothnessReport& r) { return copy_of(r.worst_edges); })
      .def_property_readonly("flipped_faces", [](const SmoothnessReport& r) { return copy_of(r.flipped_faces); })
      .def_readonly("max_crease", &SmoothnessReport::max_crease,
                    "With a deformer: the largest normal jump inside a control face (radians).")
      .def_property_readonly("face_crease", [](const SmoothnessReport& r) { return copy_of(r.face_crease); },
                             "With a deformer: per control face, the normal jump inside it (radians); empty otherwise.")
      .def_property_readonly("worst_faces", [](const SmoothnessReport& r) { return copy_of(r.worst_faces); })
      .def("to_dict", [](const SmoothnessReport& r) {
        py::list worst;
        for (int e : r.worst_edges)
          worst.append(py::make_tuple(r.edges[2 * e], r.edges[2 * e + 1], r.edge_angle[e]));
        py::dict d;
        d["max_angle"] = r.max_angle;
        d["max_angle_degrees"] = r.max_angle * 180.0 / 3.14159265358979323846;
        d["max_gap"] = r.max_gap;
        d["min_regularity"] = r.min_regularity;
        d["degenerate_samples"] = r.degenerate_samples;
        d["flipped_samples"] = r.flipped_samples;
        d["flipped_faces"] = py::cast(r.flipped_faces);
        d["interior_edges"] = r.edge_angle.size();
        d["boundary_edges"] = r.boundary_edges;
        d["sample_count"] = r.sample_count;
        d["worst_edges"] = worst;
        if (!r.face_crease.empty()) {
          py::list faces;
          for (int f : r.worst_faces) faces.append(py::make_tuple(f, r.face_crease[f]));
          d["max_crease"] = r.max_crease;
          d["max_crease_degrees"] = r.max_crease * 180.0 / 3.14159265358979323846;
          d["worst_faces"] = faces;
        }
        return d;
      }, "The scalar figures and the worst edges as [(a, b, angle), ...]: plain Python, JSON-ready.")
      .def("__repr__", [](const SmoothnessReport& r) {
        return "<SmoothnessReport max_angle " + std::to_string(r.max_angle) + " rad, max_gap " +
               std::to_string(r.max_gap) + ", " + std::to_string(r.degenerate_samples) + " degenerate, " +
               std::to_string(r.flipped_samples) + " flipped>";
      });

  def(m, "smoothness_report", [](const py::object& points, const py::object& faces, const std::string& scheme,
                                const std::string& boundary, const py::object& creases, const py::object& corners,
                                const py::object& sharpen_two_edge_vertices, std::int64_t samples_per_edge,
                                const py::object& reference, std::int64_t worst, const py::object& deformer,
                                std::int64_t crease_grid) {
    ControlMesh cage = parse_cage(points, faces, scheme, boundary, creases, corners,
                                  bool_arg(sharpen_two_edge_vertices, "sharpen_two_edge_vertices"));
    const std::shared_ptr<Deformer> map = parse_deformer(deformer);
    py::array_t<double, py::array::c_style> ref;
    if (!reference.is_none()) ref = same_cage(reference, cage.vertex_count(), "reference");
    SmoothnessReport r;
    {
      py::gil_scoped_release release;
      const LimitSurface surface(std::move(cage));
      r = smoothness_report(surface, surface.mesh().polygons.points().data(),
                            options(samples_per_edge, reference.is_none() ? nullptr : ref.data(), worst, map.get(),
                                    crease_grid));
    }
    return report_object(std::move(r));
  }, "points"_a, "faces"_a, py::kw_only(), "scheme"_a = "auto", "boundary"_a = "edge_and_corner",
     "creases"_a = py::none(), "corners"_a = py::none(), "sharpen_two_edge_vertices"_a = true,
     "samples_per_edge"_a = 8, "reference"_a = py::none(),
     "worst"_a = 10, "deformer"_a = py::none(), "crease_grid"_a = 16,
     R"(Check that the limit surface of (points, faces) is smooth: along every interior edge,
samples_per_edge points are evaluated on both faces' limit patches and compared (position gap,
normal angle). A smooth cage gives angles at machine precision (~1e-14 rad); an infinitely sharp
crease or a kink the deformation put in the cage shows as a large angle on its edges. Also counts
samples with parallel tangents (degenerate) and flipped normals: with reference (rest points of the
same topology), a normal opposing the rest surface's normal turned by the best rotation of the
control face's neighbourhood from rest to points (rigid motions, twists and bends flip nothing; a
fold does); without reference, a normal opposing its control face's own normal.

The limit surface of any cage is G1, whatever moved its points: subdivision smooths a kink a
deformation put into the cage. With deformer=F (a deformkit deformer without weights), the report
checks F(S) instead, the limit surface S of this cage mapped by F -- the surface that subdividing
first and deforming after makes -- with exact normals cof(J) (du x dv). Then face_crease holds,
per control face, the normal jump inside it: the largest second difference |n_a - 2 n_b + n_c| of
the unit normal along the lines of a (crease_grid+1)^2 sample grid per ptex face, as an angle. A
smooth map gives O(h^2) (h = 1/crease_grid); a map that is only C0 somewhere (Barr's bend at its
region ends, off the bend centre line) gives about the angle of its crease. A crease running
exactly along a control edge is not seen (both faces evaluate F's Jacobian at the same point).
A sample is then flipped where det J < 0 (reference is not used).)");
}

namespace {
py::object report_object(SmoothnessReport&& r) { return py::cast(std::move(r)); }
}  // namespace

}  // namespace deformkit_py
