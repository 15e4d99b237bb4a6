// Python bindings of the surface deformers: argument conversion and checking only.
#include "common.hpp"
#include "declared.hpp"

#include "deformkit/surface/drag_start.hpp"
#include "deformkit/surface/surface_deformer.hpp"

#include <cmath>
#include <memory>
#include <optional>

namespace deformkit_py {

using namespace pybind11::literals;

namespace {

// The mesh fanned into triangles, its polygons simple (no vertex twice in one face).
PolygonMesh parse_mesh(const py::object& points, const py::object& faces) {
  PolygonMesh mesh = parse_polygon_mesh(points, faces);
  require_distinct_corners(mesh);
  return std::move(mesh).triangulate();
}

const EnumNames<SurfaceMethod> kMethodNames("method", {{"arap", SurfaceMethod::Arap},
                                                       {"rotation_invariant", SurfaceMethod::RotationInvariant},
                                                       {"laplacian", SurfaceMethod::Laplacian}});
const EnumNames<bool> kUniformWeightNames("weights", {{"cotangent", false}, {"uniform", true}});

std::vector<int> parse_indices(const py::object& obj, const char* name, std::size_t n) {
  if (obj.is_none()) return {};
  const std::vector<std::int64_t> v =
      parse_index_array(obj, name, "a sequence of integer vertex indices", [&](const py::array& a) {
        if (a.ndim() > 1) throw py::value_error(std::string(name) + ": expected a 1-D sequence of vertex indices");
      });
  std::vector<int> out;
  for (const std::int64_t x : v) {
    if (x < 0 || std::uint64_t(x) >= n)
      throw py::value_error(std::string(name) + ": index " + std::to_string(x) + " is outside 0.." + std::to_string(n - 1));
    out.push_back(static_cast<int>(x));
  }
  return out;
}

}  // namespace

void bind_surface(py::module_& m) {
  def(m, "cotangent_laplacian", [](const py::object& points, const py::object& faces) {
    const PolygonMesh mesh = parse_mesh(points, faces);
    SparseMatrix l = cotangent_laplacian(mesh);  // symmetric: its column storage is its row storage
    l.makeCompressed();
    return csr_tuple({l.outerIndexPtr(), l.outerIndexPtr() + l.outerSize() + 1},
                     {l.innerIndexPtr(), l.innerIndexPtr() + l.nonZeros()}, {l.valuePtr(), l.valuePtr() + l.nonZeros()});
  }, "points"_a, "faces"_a, R"(The cotangent Laplacian of a mesh as CSR (indptr, indices, data).

L_ij = -(cot a + cot b)/2 for an edge, L_ii = -sum of the row: symmetric, rows sum to 0. Polygons
are fanned into triangles; cotangents are clamped to +-1e4 so degenerate triangles stay finite.)");

  def(m, "extrapolated_start", [](const py::object& previous, const py::object& earlier, const py::object& targets,
                                 const py::object& previous_targets, const py::object& earlier_targets) {
    auto rows3 = [](const py::object& obj, const char* name, py::ssize_t rows, const char* like) {
      const py::array a = points_array(obj, name);
      if (rows >= 0 && a.shape(0) != rows)
        throw py::value_error(std::string(name) + ": expected shape (" + std::to_string(rows) + ", 3)" + like +
                              ", got " + shape_of(a));
      auto d = as_double(a, name);
      for (py::ssize_t i = 0; i < d.shape(0); ++i)
        if (!std::isfinite(d.at(i, 0)) || !std::isfinite(d.at(i, 1)) || !std::isfinite(d.at(i, 2)))
          throw py::value_error(std::string(name) + ": row " + std::to_string(i) + " is not finite");
      return d;
    };
    const auto p = rows3(previous, "previous", -1, "");
    const auto e = rows3(earlier, "earlier", p.shape(0), ", like previous");
    const auto t = rows3(targets, "targets", -1, "");
    const auto pt = rows3(previous_targets, "previous_targets", t.shape(0), ", like targets");
    const auto et = rows3(earlier_targets, "earlier_targets", t.shape(0), ", like targets");
    std::vector<double> out;
    without_gil("the extrapolated start", [&] {
      out = extrapolated_start(p.data(), e.data(), std::size_t(p.shape(0)), t.data(), pt.data(), et.data(),
                               std::size_t(t.shape(0)));
    });
    return owned_array(std::move(out), {p.shape(0), 3});
  }, "previous"_a, "earlier"_a, "targets"_a, "previous_targets"_a, "earlier_targets"_a,
     R"(An initial guess for SurfaceDeformer.deform(targets, initial=...) over a drag: the last two
results previous and earlier (n, 3) extrapolated, previous + s (previous - earlier), s the handles'
present step (targets - previous_targets) projected on their last (previous_targets -
earlier_targets), clipped to [0, 2]: 0, previous itself, when they stood still or turn back or
across. A first-order predictor: ARAP from it converges in fewer iterations than from previous.)");

  def(m, "_forget_remembered_orderings", &SurfaceDeformer::forget_remembered_orderings,
        "For benchmarks: forget the fill-reducing orderings that binds remember per connectivity, so that the next "
        "bind of any mesh orders its system from scratch.");

  Class<SurfaceDeformer, std::shared_ptr<SurfaceDeformer>>(m, "SurfaceDeformer", R"(Laplacian editing and as-rigid-as-possible deformation of a mesh.

points (n, 3) and faces (an (m, k) integer array or a list of polygons) are copied. anchors stay
at rest, handles move to the targets given to deform(); vertices outside roi (default: all
inside) stay at rest; a handle outside roi still goes to its target. method 'arap' (Sorkine and
Alexa 2007: local rotations, global solve; iterations local/global steps, stopping early when the
relative energy decrease falls below tolerance > 0), 'rotation_invariant' (Sorkine et al. 2004,
sec. 4: each vertex's differential coordinate follows the similarity transform, linearised, that
its one-ring undergoes; then, iterations times, each one-ring's rotation is taken from that
solution and the differential coordinates, rotated by it without the linearisation's scale, are
solved for again) or 'laplacian' (least squares on the differential coordinates, no rotations);
weights 'cotangent' or 'uniform'. The systems over the free vertices are factorised here, once;
deform() only back-substitutes. Negative cotangent weights are
raised to a small positive floor, which keeps the system positive definite and the ARAP energy
monotone. A connected component with no anchor or handle stays where it is (see warnings).
constraint_weight None makes anchors and handles hard constraints, met exactly; a number w in
[1e-4, 1e8] makes them soft: each adds w^2 ||x_i - c_i||^2 to the least-squares energy (Sorkine et al. 2004,
eq. 5), or 2 w^2 ||x_i - c_i||^2 to the ARAP energy (whose sum over edges counts each edge twice),
so that they are met only approximately, more closely as w grows. anderson m in 1..50 (ARAP
only; default 0, the plain alternation) accelerates the local/global steps by Anderson mixing of
the last m (Peng et al. 2018), keeping a mixed step only when it lowers the energy; energy then
records each iterate's energy with its best rotations.)")
      .def(py::init([](const py::object& points, const py::object& faces, const py::object& anchors,
                       const py::object& handles, const py::object& roi, const std::string& method,
                       const std::string& weights, std::int64_t iterations, double tolerance,
                       const std::optional<double>& constraint_weight, std::int64_t anderson) {
             SurfaceSettings s;
             s.method = kMethodNames.parse(method);
             s.uniform_weights = kUniformWeightNames.parse(weights);
             s.iterations = int_arg(iterations, "iterations", 1, 10000);
             s.tolerance = tolerance;
             s.anderson = int_arg(anderson, "anderson", 0, 50);
             s.constraint_weight = constraint_weight;  // its range is checked (and named) by the core
             PolygonMesh mesh = parse_mesh(points, faces);
             std::optional<std::vector<int>> region;
             const std::size_t n = mesh.vertex_count();
             if (!roi.is_none()) region = parse_indices(roi, "roi", n);
             auto a = parse_indices(anchors, "anchors", n), h = parse_indices(handles, "handles", n);
             py::gil_scoped_release release;
             return std::make_shared<SurfaceDeformer>(std::move(mesh), std::move(a), std::move(h), region, s);
           }),
           "points"_a, "faces"_a, py::kw_only(), "anchors"_a = py::tuple(), "handles"_a = py::tuple(),
           "roi"_a = py::none(), "method"_a = "arap", "weights"_a = "cotangent", "iterations"_a = 10,
           "tolerance"_a = 0.0, "constraint_weight"_a = py::none(), "anderson"_a = 0)
      .def("deform", [](SurfaceDeformer& d, const py::object& targets, const py::object& initial) {
        const auto k = py::ssize_t(d.handle_count());
        const auto td = real_array(targets, "handle_targets");
        if (td.ndim() != 2 || td.shape(0) != k || td.shape(1) != 3)
          throw py::value_error("handle_targets: expected shape (" + std::to_string(k) + ", 3), got " + shape_of(td));
        std::optional<py::array_t<double, py::array::c_style>> guess;
        if (!initial.is_none()) {
          const py::array g = points_array(initial, "initial");
          if (g.ndim() != 2 || g.shape(0) != py::ssize_t(d.vertex_count()))
            throw py::value_error("initial: expected shape (" + std::to_string(d.vertex_count()) +
                                  ", 3), a position per vertex (e.g. the previous deform's result), got " + shape_of(g));
          guess = as_double(g, "initial");
        }
        const double* gp = guess ? guess->data() : nullptr;
        std::vector<double> out;
        without_gil("the deformed points", [&] { out = d.deform(td.data(), gp); });
        auto result = new_array<double>({py::ssize_t(d.vertex_count()), py::ssize_t(3)}, "the deformed points");
        std::copy(out.begin(), out.end(), result.mutable_data());
        return result;
      }, "handle_targets"_a, "initial"_a = py::none(),
         "Deformed points (n, 3) with the handles at handle_targets (len(handles), 3). initial (n, 3): "
         "ARAP starts from the rotations fitting these positions (e.g. the previous result) instead of "
         "R = I, converging in fewer iterations for a small handle move; the linear methods ignore it.")
      .def("__len__", &SurfaceDeformer::vertex_count)
      .def_property_readonly("free_count", &SurfaceDeformer::free_count)
      .def_property_readonly("warnings", &SurfaceDeformer::warnings)
      .def_property_readonly("factor_nonzeros", &SurfaceDeformer::factor_nonzeros,
                             "Non-zeros of the Cholesky factor (memory and solve time grow with it).")
      .def_property_readonly("bind_stages", [](const SurfaceDeformer& d) {
        py::list out;
        for (const Stage& s : d.bind_stages()) out.append(py::make_tuple(s.name, s.seconds, s.cpu_seconds, s.page_faults));
        return out;
      }, "Where the construction spent its time, for benchmarks: (stage, wall seconds, the constructing thread's "
         "CPU seconds, minor page faults) in order.")
      .def_property_readonly("energy", &SurfaceDeformer::energy, "ARAP energy after each iteration of the last deform.")
      .def_property_readonly("method", [](const SurfaceDeformer& d) { return kMethodNames.name(d.settings().method); })
      .def_property_readonly("weights_kind", [](const SurfaceDeformer& d) {
        return kUniformWeightNames.name(d.settings().uniform_weights);
      });
}

}  // namespace deformkit_py
