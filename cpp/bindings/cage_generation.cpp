// Python binding of generate_cage (the cage family's generator): argument conversion and checking only.
#include "common.hpp"
#include "declared.hpp"

#include "deformkit/cage/generate_cage.hpp"

#include <string>

namespace deformkit_py {

using namespace pybind11::literals;

namespace {

// None, an empty list or an array of no rows: a point cloud.
bool no_faces(const py::object& faces) {
  if (faces.is_none()) return true;
  if (py::isinstance<py::array>(faces)) return py::reinterpret_borrow<py::array>(faces).size() == 0;
  return sequence_length(faces) == 0;
}

// Every face fanned from its first corner (c0, ci, ci+1); a face of one or two corners is kept as
// a degenerate triangle (a point, a segment), which the generator wraps as such.
std::vector<std::array<int, 3>> fanned(const py::object& faces, std::size_t n) {
  std::vector<std::array<int, 3>> out;
  if (no_faces(faces)) return out;
  Faces f;
  if (py::isinstance<py::array>(faces) && py::reinterpret_borrow<py::array>(faces).ndim() == 2 &&
      py::reinterpret_borrow<py::array>(faces).shape(1) < 3) {
    const py::array a = py::reinterpret_borrow<py::array>(faces);
    if (a.dtype().kind() != 'i' && a.dtype().kind() != 'u')
      throw py::type_error("faces: expected integer vertex indices, got " + std::string(py::str(a.dtype())));
    const auto c = c_array<std::int64_t>(a, "faces");
    f.corners.assign(c.data(), c.data() + c.size());
    f.offsets.push_back(0);
    for (py::ssize_t i = 1; i <= c.shape(0); ++i) f.offsets.push_back(i * c.shape(1));
  } else {
    f = parse_faces(faces);
  }
  for (std::size_t k = 0; k + 1 < f.offsets.size(); ++k) {
    const std::int64_t b = f.offsets[k], e = f.offsets[k + 1];
    for (std::int64_t c = b; c < e; ++c)
      if (f.corners[std::size_t(c)] < 0 || f.corners[std::size_t(c)] >= std::int64_t(n))
        throw py::value_error("faces: expected vertex indices in 0.." + std::to_string(std::int64_t(n) - 1) + ", got " +
                              std::to_string(f.corners[std::size_t(c)]) + " in face " + std::to_string(k));
    if (e == b) throw py::value_error("faces: face " + std::to_string(k) + " has no corners");
    const int c0 = int(f.corners[std::size_t(b)]);
    if (e - b < 3) {
      out.push_back({c0, int(f.corners[std::size_t(e - 1)]), int(f.corners[std::size_t(e - 1)])});
      continue;
    }
    for (std::int64_t c = b + 1; c + 1 < e; ++c)
      out.push_back({c0, int(f.corners[std::size_t(c)]), int(f.corners[std::size_t(c + 1)])});
  }
  return out;
}

py::tuple py_generate_cage(const py::object& points, const py::object& faces, std::int64_t max_faces,
                           const std::optional<double>& offset, const std::optional<double>& alpha,
                           const py::object& quads) {
  const py::array p0 = points_array(points, "points");
  const auto p = as_double(p0);
  const std::vector<double> pts(p.data(), p.data() + p.size());
  const auto tris = fanned(faces, pts.size() / 3);
  CageGenerationOptions o;
  o.max_faces = int_arg(max_faces, "max_faces", 4, 1 << 24);
  if (offset) {
    o.offset = finite_param(*offset, "offset");
    if (!(o.offset > 0)) throw py::value_error("offset: expected a positive distance, got " + std::to_string(o.offset));
  }
  if (alpha) {
    o.alpha = finite_param(*alpha, "alpha");
    if (!(o.alpha > 0)) throw py::value_error("alpha: expected a positive length, got " + std::to_string(o.alpha));
  }
  o.quads = bool_arg(quads, "quads");
  GeneratedCage cage;
  std::string error;
  without_gil("the cage generation", [&] {
    try {
      cage = generate_cage(pts, tris, o);
    } catch (const std::invalid_argument& e) {
      error = e.what();
    }
  });
  if (!error.empty()) throw py::value_error(error);
  py::array cp = copied_array(cage.points.data(), {py::ssize_t(cage.points.size() / 3), 3});
  if (!o.quads) return py::make_tuple(cp, copied_array(cage.corners.data(), {py::ssize_t(cage.corners.size() / 3), 3}));
  py::list polys;
  for (std::size_t f = 0; f + 1 < cage.offsets.size(); ++f) {
    py::list poly;
    for (std::int64_t c = cage.offsets[f]; c < cage.offsets[f + 1]; ++c) poly.append(cage.corners[std::size_t(c)]);
    polys.append(poly);
  }
  return py::make_tuple(cp, polys);
}

}  // namespace

void bind_cage_generation(py::module_& m) {
  def(m, "generate_cage", &py_generate_cage, "points"_a, "faces"_a = py::none(), py::kw_only(), "max_faces"_a = 200,
      "offset"_a = py::none(), "alpha"_a = py::none(), "quads"_a = false,
      R"(A cage made for a mesh: (cage_points (k, 3) float64, cage_faces).

A closed, 2-manifold, outward-oriented, self-intersection-free cage of at most max_faces faces that strictly encloses
every point, edge and face of the mesh (docs/cage.md, "Generated cages"): CGAL's alpha wrap at `offset` (default
1/100 of the bounding-box diagonal) with detail `alpha` (default: coarser for smaller budgets), simplified by edge collapses that only
grow the enclosed region. faces: (m, k) indices, a list of polygons, or None for a point cloud; any mesh (several
parts, open, non-manifold, self-intersecting, flat, a segment or a point). cage_faces is an (f, 3) int32 array, or
with quads=True a list of quads and triangles (pairs merged where the cage deformers split them back alike).)");
}

}  // namespace deformkit_py
