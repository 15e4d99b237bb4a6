// Python bindings of the RBF family: argument conversion and checking only.
#include "common.hpp"
#include "declared.hpp"

#include <memory>
#include <optional>
#include <string>

namespace deformkit_py {

using namespace pybind11::literals;

namespace {

// A binding remembers its RBF: a compact kernel's table holds that RBF's kernel values.
struct PyRbfBinding {
  std::shared_ptr<RbfBinding> binding;
  std::shared_ptr<const RbfDeformer> rbf;
};

const EnumNames<RbfKernel> kKernelNames(
    "kernel", {{"thin_plate_spline", RbfKernel::ThinPlateSpline}, {"cubic", RbfKernel::Cubic},
               {"quintic", RbfKernel::Quintic}, {"linear", RbfKernel::Linear}, {"gaussian", RbfKernel::Gaussian},
               {"multiquadric", RbfKernel::Multiquadric}, {"inverse_multiquadric", RbfKernel::InverseMultiquadric},
               {"inverse_quadratic", RbfKernel::InverseQuadratic}, {"wendland_c0", RbfKernel::WendlandC0},
               {"wendland_c2", RbfKernel::WendlandC2}, {"wendland_c4", RbfKernel::WendlandC4},
               {"clip", RbfKernel::Clip}});

bool scale_invariant(RbfKernel k) {
  return k == RbfKernel::ThinPlateSpline || k == RbfKernel::Cubic || k == RbfKernel::Quintic || k == RbfKernel::Linear;
}

// (m, 3) real points, copied as float64; `count` (if not negative) is the row count required.
std::vector<double> parse_rows(const py::object& obj, const char* name, py::ssize_t count) {
  const py::array a = points_array(obj, name);
  if (count >= 0 && a.shape(0) != count)
    throw py::value_error(std::string(name) + ": expected shape (" + std::to_string(count) + ", 3), one row per control, got " +
                          shape_of(a));
  const auto d = as_double(a, name);
  return std::vector<double>(d.data(), d.data() + d.size());
}

RbfOptions parse_options(const std::string& kernel, const std::optional<double>& epsilon,
                         const std::optional<double>& radius, const std::optional<std::int64_t>& degree, double smoothing) {
  RbfOptions o;
  o.kernel.kind = kKernelNames.parse(kernel);
  const std::string name = kKernelNames.name(o.kernel.kind);
  if (rbf_compact(o.kernel.kind)) {
    if (epsilon) throw py::value_error("epsilon: the " + name + " kernel has a support radius, not epsilon; give radius=");
    if (!radius) throw py::value_error("radius: the " + name + " kernel needs its support radius (radius=R > 0)");
    o.kernel.radius = finite_param(*radius, "radius");
  } else {
    if (radius) throw py::value_error("radius: the " + name + " kernel is global; radius is for the compact kernels "
                                      "(wendland_c0, wendland_c2, wendland_c4, clip)");
    if (!epsilon && !scale_invariant(o.kernel.kind))
      throw py::value_error("epsilon: the " + name + " kernel needs its shape parameter (epsilon=e > 0), as scipy's");
    if (epsilon) o.kernel.epsilon = finite_param(*epsilon, "epsilon");
  }
  // scipy 1.14's RBFInterpolator default: max(the kernel's minimum degree, 0), the compact kernels alike.
  o.degree = degree ? int_arg(*degree, "degree", -1, 2) : std::max(0, rbf_minimum_degree(o.kernel.kind));
  o.smoothing = finite_param(smoothing, "smoothing");
  return o;
}

py::array rows_of(const std::vector<double>& p) {
  return copied_array(p.data(), {py::ssize_t(p.size() / 3), py::ssize_t(3)});
}

}  // namespace

void bind_rbf(py::module_& m) {
  Class<PyRbfBinding>(m, "RBFBinding", R"(Points bound to an RBF (RBF.bind).

For a compact kernel it holds each point's kernel values at the controls within the support, so
deform_bound is one sparse product with the coefficients; for a global kernel it holds the points
only (a table would be n x m) and deform_bound evaluates the kernel sums again.)")
      .def("__len__", [](const PyRbfBinding& b) { return b.binding->size(); })
      .def_property_readonly("nonzeros", [](const PyRbfBinding& b) { return b.binding->table.values.size(); },
                             "Stored kernel values (compact kernels; 0 for a global kernel).")
      .def("weights", [](const PyRbfBinding& b) {
        WeightTable w = b.binding->table;
        return csr_tuple(std::move(w.indptr), std::move(w.indices), std::move(w.values));
      }, "Compact kernels: the kernel values phi(|x_i - c_j|) as CSR (indptr, indices, data).");

  Class<RbfDeformer, Deformer, std::shared_ptr<RbfDeformer>>(m, "RBF", R"(Radial basis function deformation (de Boer, van der Schoot, Bijl 2007).

control_points (m, 3) move to targets (m, 3; default: the controls, the identity); every other
point x moves by d(x) = sum_j alpha_j phi(|x - c_j|) + p(x), the interpolant of the controls'
displacements with a polynomial p of `degree` (-1 none, 0 constant, 1 affine, 2 quadratic; default
max(the kernel's minimum, 0), as scipy's: 1 for thin_plate_spline and cubic, 2 for quintic, else 0). Kernels and their parameters are scipy.interpolate.
RBFInterpolator's: 'thin_plate_spline' (default), 'cubic', 'quintic', 'linear', 'gaussian',
'multiquadric', 'inverse_multiquadric', 'inverse_quadratic', with phi evaluated at epsilon * r
(epsilon required for the last four); plus compactly supported 'wendland_c0', 'wendland_c2',
'wendland_c4' and 'clip' (the RBF note's (1 - r/R)^2, equal to wendland_c0) with a support
`radius`. `smoothing` >= 0 is added to the kernel matrix's diagonal (regularised least squares),
as scipy's. The system is factorised once: assigning `targets` costs solves, not a new fit.
Jacobians are exact.)")
      .def(py::init([](const py::object& controls, const py::object& targets, const std::string& kernel,
                       const std::optional<double>& epsilon, const std::optional<double>& radius,
                       const std::optional<std::int64_t>& degree, double smoothing, const py::object& weights) {
             const RbfOptions o = parse_options(kernel, epsilon, radius, degree, smoothing);
             const std::vector<double> c = parse_rows(controls, "control_points", -1);
             std::optional<std::vector<double>> t;
             if (!targets.is_none()) t = parse_rows(targets, "targets", py::ssize_t(c.size() / 3));
             std::shared_ptr<RbfDeformer> rbf;
             without_gil("the RBF system of " + std::to_string(c.size() / 3) + " controls", [&] {
               rbf = std::make_shared<RbfDeformer>(c.data(), c.size() / 3, o);
               if (t) rbf->set_targets(std::move(*t));
             });
             apply_weights(*rbf, weights);
             return rbf;
           }),
           "control_points"_a, "targets"_a = py::none(), py::kw_only(), "kernel"_a = "thin_plate_spline",
           "epsilon"_a = py::none(), "radius"_a = py::none(), "degree"_a = py::none(), "smoothing"_a = 0.0,
           "weights"_a = py::none())
      .def_property_readonly("control_points", [](const RbfDeformer& r) { return rows_of(r.control_points()); },
                             "The controls (m, 3), as given (a copy).")
      .def_property("targets", [](const RbfDeformer& r) { return rows_of(r.targets()); },
                    [](RbfDeformer& r, const py::object& t) {
                      std::vector<double> v = parse_rows(t, "targets", py::ssize_t(r.control_count()));
                      without_gil("the RBF coefficients", [&] { r.set_targets(std::move(v)); });
                    },
                    "Where the controls go (m, 3); assigning copies and solves with the kept factorisation.")
      .def_property_readonly("kernel", [](const RbfDeformer& r) { return kKernelNames.name(r.options().kernel.kind); })
      .def_property_readonly("epsilon", [](const RbfDeformer& r) -> py::object {
        if (rbf_compact(r.options().kernel.kind)) return py::none();
        return py::float_(r.options().kernel.epsilon);
      })
      .def_property_readonly("radius", [](const RbfDeformer& r) -> py::object {
        if (!rbf_compact(r.options().kernel.kind)) return py::none();
        return py::float_(r.options().kernel.radius);
      })
      .def_property_readonly("degree", [](const RbfDeformer& r) { return r.options().degree; })
      .def_property_readonly("smoothing", [](const RbfDeformer& r) { return r.options().smoothing; })
      .def_property_readonly("condition_estimate", &RbfDeformer::condition_estimate,
                             "1-norm condition estimate of the factorised dense system (NaN for compact kernels).")
      .def_property_readonly("coefficients", [](const RbfDeformer& r) {
        return py::make_tuple(rows_of(r.alpha()), rows_of(r.beta()));
      }, "(alpha (m, 3), beta (terms, 3)): the kernel and polynomial coefficients (docs/math/rbf.md).")
      .def("bind", [](const std::shared_ptr<RbfDeformer>& r, const py::object& points) {
             const py::array pts = points_array(points, "points");
             const auto n = static_cast<std::size_t>(pts.shape(0));
             auto b = std::make_shared<RbfBinding>();
             without_gil("the RBF binding of " + std::to_string(n) + " points", [&] {
               if (is_float32(pts)) *b = r->bind(static_cast<const float*>(pts.data()), n);
               else *b = r->bind(static_cast<const double*>(pts.data()), n);
             });
             return PyRbfBinding{b, r};
           }, "points"_a, "Bind points: what does not depend on the targets, kept (RBFBinding).")
      .def("deform_bound", [](const RbfDeformer& r, const PyRbfBinding& pb, const py::object& out) {
             const RbfBinding& b = *pb.binding;
             const auto rows = py::ssize_t(b.size());
             py::array result = b.single_precision ? output_array<float>(out, rows, py::none(), false)
                                                   : output_array<double>(out, rows, py::none(), false);
             without_gil("the RBF's working arrays", [&] {
               if (b.single_precision) r.deform_bound(b, static_cast<float*>(result.mutable_data()));
               else r.deform_bound(b, static_cast<double*>(result.mutable_data()));
             });
             return result;
           }, "binding"_a, py::kw_only(), "out"_a = py::none(),
           "Deform bound points with the current targets. The dtype is that of the bound points.");
}

}  // namespace deformkit_py
