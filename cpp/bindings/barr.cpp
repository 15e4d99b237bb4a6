// Python bindings of Barr's deformers and Blender's Simple Deform.
#include "common.hpp"
#include "declared.hpp"

#include <optional>
#include <string>

namespace deformkit_py {

using namespace pybind11::literals;

namespace {

const EnumNames<SimpleDeformMode> kModeNames("mode", {{"TWIST", SimpleDeformMode::Twist},
                                                     {"BEND", SimpleDeformMode::Bend},
                                                     {"TAPER", SimpleDeformMode::Taper},
                                                     {"STRETCH", SimpleDeformMode::Stretch}});

std::shared_ptr<BarrDeformer> py_bind_simple(const SimpleDeform& d, const py::object& points) {
  const py::array pts = points_array(points, "points");
  const auto n = static_cast<std::size_t>(pts.shape(0));
  std::shared_ptr<BarrDeformer> map;
  without_gil("the bounding pass", [&] {
    if (is_float32(pts)) map = d.bind(static_cast<const float*>(pts.data()), n);
    else map = d.bind(static_cast<const double*>(pts.data()), n);
  });
  return map;
}

// SimpleDeform.replace: the settings given (not None) parsed as the constructor parses them.
std::shared_ptr<SimpleDeform> py_replace_simple(const SimpleDeform& d, const py::object& mode, const py::object& angle,
                                                const py::object& factor, const py::object& deform_axis,
                                                const py::object& origin, const py::object& limits,
                                                const py::object& lock_x, const py::object& lock_y,
                                                const py::object& lock_z) {
  SimpleDeformSettings s = d.settings();
  if (!angle.is_none() && !factor.is_none())
    throw py::value_error("angle: give angle or factor (they are one value), not both");
  if (!mode.is_none()) {
    if (!py::isinstance<py::str>(mode))
      throw py::type_error("mode: expected 'TWIST', 'BEND', 'TAPER' or 'STRETCH', got " + std::string(py::repr(mode)));
    s.mode = kModeNames.parse(py::cast<std::string>(mode));
  }
  for (const auto& [value, name] : {std::pair{&angle, "angle"}, std::pair{&factor, "factor"}}) {
    if (value->is_none()) continue;
    if (py::isinstance<py::str>(*value) || !PyNumber_Check(value->ptr()))
      throw py::type_error(std::string(name) + ": expected a number, got " + std::string(py::repr(*value)));
    s.factor = finite_param(py::cast<double>(py::float_(*value)), name);
  }
  if (!deform_axis.is_none()) s.deform_axis = parse_axis(deform_axis, "deform_axis");
  if (!origin.is_none()) s.origin = parse_frame(origin, "origin");
  if (!limits.is_none()) std::tie(s.limit_lo, s.limit_hi) = parse_range(limits, "limits");
  const py::object* locks[3] = {&lock_x, &lock_y, &lock_z};
  const char* lock_names[3] = {"lock_x", "lock_y", "lock_z"};
  for (int a = 0; a < 3; ++a)
    if (!locks[a]->is_none()) s.lock[a] = bool_arg(*locks[a], lock_names[a]);
  auto replaced = std::make_shared<SimpleDeform>(s);
  replaced->share_weights(d);
  return replaced;
}

}  // namespace

void bind_barr(py::module_& m) {
  Class<BarrDeformer, Deformer, std::shared_ptr<BarrDeformer>>(m, "BarrDeformer", R"(A Barr operator placed in object space: the fixed map SimpleDeform.bind(points) returns.

The extent it spreads the amount over was measured once, on the bound points, so deforming any
part of them gives what deforming all of them does; it carries the SimpleDeform's weights.)");

  Class<Twist, Deformer, std::shared_ptr<Twist>>(m, "Twist", R"(Barr's twist about an axis.

x' = x cos(t) - y sin(t), y' = x sin(t) + y cos(t), z' = z with t = f(z) (Barr 1984, twisting).
By default f(z) = rate * clamp(z, limits) (limits None: unbounded); with `profile=(z, theta)` f is
the natural cubic spline through the samples, held constant (extend='constant') or continued
along its end tangents (extend='linear') outside them. `axis` is the twist axis; `frame` (4x4)
places the deformer's coordinates in object space.)")
      .def(py::init([](std::optional<double> rate, const py::object& axis, const py::object& limits,
                       const py::object& profile, const std::string& extend, const py::object& frame,
                       const py::object& weights) {
             auto d = std::make_shared<Twist>(parse_law(0.0, rate, limits, profile, extend), parse_axis(axis, "axis"),
                                              parse_frame(frame, "frame"));
             apply_weights(*d, weights);
             return d;
           }),
           "rate"_a = py::none(), "axis"_a = "z", "limits"_a = py::none(), "profile"_a = py::none(),
           "extend"_a = "constant", "frame"_a = py::none(), "weights"_a = py::none());

  Class<Taper, Deformer, std::shared_ptr<Taper>>(m, "Taper", R"(Barr's taper along an axis.

x' = r x, y' = r y, z' = z with r = f(z) (Barr 1984, tapering; det J = r^2). By default
f(z) = 1 + rate * clamp(z, limits); `profile=(z, r)` gives r by a natural cubic spline.)")
      .def(py::init([](std::optional<double> rate, const py::object& axis, const py::object& limits,
                       const py::object& profile, const std::string& extend, const py::object& frame,
                       const py::object& weights) {
             auto d = std::make_shared<Taper>(parse_law(1.0, rate, limits, profile, extend), parse_axis(axis, "axis"),
                                              parse_frame(frame, "frame"));
             apply_weights(*d, weights);
             return d;
           }),
           "rate"_a = py::none(), "axis"_a = "z", "limits"_a = py::none(), "profile"_a = py::none(),
           "extend"_a = "constant", "frame"_a = py::none(), "weights"_a = py::none());

  Class<Stretch, Deformer, std::shared_ptr<Stretch>>(m, "Stretch", R"(Blender's stretch along an axis.

With z^ = clamp(z, limits) and s = 1 + k (z^2 - 1): x' = s x, y' = s y, z' = z + k z^
(MOD_simpledeform). Approximately volume preserving near |z| = 1 only.)")
      .def(py::init([](double factor, const py::object& axis, const py::object& limits, const py::object& frame,
                       const py::object& weights) {
             const auto [lo, hi] = parse_range(limits, "limits");
             auto d = std::make_shared<Stretch>(finite_param(factor, "factor"), lo, hi, parse_axis(axis, "axis"),
                                                parse_frame(frame, "frame"));
             apply_weights(*d, weights);
             return d;
           }),
           "factor"_a = 0.785398163397448, "axis"_a = "z", "limits"_a = py::none(), "frame"_a = py::none(),
           "weights"_a = py::none());

  Class<Bend, Deformer, std::shared_ptr<Bend>>(m, "Bend", R"(Barr's bend.

In canonical coordinates x is kept and the y axis bends toward +z on a circle of radius 1/k:
t = k (y^ - y0) with y^ = clamp(y, region); y' = -sin(t)(z - 1/k) + y0 + cos(t)(y - y^),
z' = cos(t)(z - 1/k) + 1/k + sin(t)(y - y^) (Barr 1984, bending; outside the region the ends
continue along the tangent). det J = 1 - k z inside the region. Evaluated in a half-angle
form that tends to the identity as k -> 0. `axis` is the kept axis (canonical x); the
length and bend directions follow cyclically (axis='z': length along x, bends toward y).)")
      .def(py::init([](double curvature, double center, const py::object& region, const py::object& axis,
                       const py::object& frame, const py::object& weights) {
             const auto [lo, hi] = parse_range(region, "region");
             auto d = std::make_shared<Bend>(finite_param(curvature, "curvature"), finite_param(center, "center"), lo,
                                             hi, parse_axis(axis, "axis"), parse_frame(frame, "frame"));
             apply_weights(*d, weights);
             return d;
           }),
           "curvature"_a = 0.785398163397448, "center"_a = 0.0, "region"_a = py::none(), "axis"_a = "x",
           "frame"_a = py::none(), "weights"_a = py::none());

  Class<SimpleDeform, Deformer, std::shared_ptr<SimpleDeform>>(m, "SimpleDeform",
                                                                     R"(Blender's Simple Deform modifier, reproduced.

Settings as in Blender: mode ('TWIST', 'BEND', 'TAPER', 'STRETCH'), angle (twist, bend) or
factor (taper, stretch) -- one value, as in Blender --, deform_axis, origin (4x4 matrix of the
origin object in this object's local space, i.e. inverse(object.matrix_world) @
origin.matrix_world), limits (fractions of the bounding extent), lock_x/y/z, weights (the vertex
group) and invert_weights. As in Blender, the amount is spread over the limited extent of the
points given: k = amount / (L1 - L0), measured in the origin frame on each call; the Jacobian
is that of the map with these bounds held fixed.)")
      .def(py::init([](const std::string& mode, std::optional<double> angle, std::optional<double> factor,
                       const py::object& deform_axis, const py::object& origin, const py::object& limits,
                       const py::object& lock_x, const py::object& lock_y, const py::object& lock_z,
                       const py::object& weights, const py::object& invert_weights_arg) {
             const bool invert_weights = bool_arg(invert_weights_arg, "invert_weights");
             if (angle && factor) throw py::value_error("angle: give angle or factor (they are one value), not both");
             SimpleDeformSettings s;
             s.mode = kModeNames.parse(mode);
             s.factor = finite_param(angle ? *angle : factor.value_or(0.785398163397448), angle ? "angle" : "factor");
             s.deform_axis = parse_axis(deform_axis, "deform_axis");
             s.origin = parse_frame(origin, "origin");
             const auto [lo, hi] = parse_range(limits, "limits");
             s.limit_lo = lo;
             s.limit_hi = hi;
             s.lock = {bool_arg(lock_x, "lock_x"), bool_arg(lock_y, "lock_y"), bool_arg(lock_z, "lock_z")};
             auto d = std::make_shared<SimpleDeform>(s);
             if (!weights.is_none()) {
               auto w = parse_vector(weights, "weights");
               if (invert_weights)
                 for (double& x : w) x = 1.0 - x;
               d->set_weights(std::move(w));
             } else if (invert_weights) {
               throw py::value_error("invert_weights: needs weights");
             }
             return d;
           }),
           "mode"_a = "TWIST", "angle"_a = py::none(), "factor"_a = py::none(), "deform_axis"_a = "X",
           "origin"_a = py::none(), "limits"_a = py::make_tuple(0.0, 1.0), "lock_x"_a = false, "lock_y"_a = false,
           "lock_z"_a = false, "weights"_a = py::none(), "invert_weights"_a = false)
      .def("replace", &py_replace_simple, py::kw_only(), "mode"_a = py::none(), "angle"_a = py::none(),
           "factor"_a = py::none(), "deform_axis"_a = py::none(), "origin"_a = py::none(), "limits"_a = py::none(),
           "lock_x"_a = py::none(), "lock_y"_a = py::none(), "lock_z"_a = py::none(),
           R"(A SimpleDeform with the settings given (not None) changed and the others as this one's.

It shares this one's weights (no copy, no new check), so a parameter edit under a large vertex
group costs nothing per point; origin=None keeps the origin (pass numpy.eye(4) for none).)")
      .def("bind", &py_bind_simple, "points"_a, R"(The fixed spatial map deform(points) applies (a BarrDeformer).

The extent is measured on `points` once; the map then measures nothing, so splitting points
into chunks never changes a result: deforming A and B with it equals deform(A | B) bit for bit.
It carries these weights, which must count `points`.)")
      .def_property_readonly("mode", [](const SimpleDeform& d) { return kModeNames.name(d.settings().mode); })
      .def_property_readonly("angle", [](const SimpleDeform& d) { return d.settings().factor; })
      .def_property_readonly("factor", [](const SimpleDeform& d) { return d.settings().factor; })
      .def_property_readonly("deform_axis", [](const SimpleDeform& d) { return std::string(1, "XYZ"[d.settings().deform_axis]); })
      .def_property_readonly("limits", [](const SimpleDeform& d) {
        return py::make_tuple(d.settings().limit_lo, d.settings().limit_hi);
      });

}

}  // namespace deformkit_py
