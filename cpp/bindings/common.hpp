#pragma once
// Argument conversion shared by the binding files, and the methods every deformer exposes.
#include "deformkit/deformkit.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace deformkit_py {

namespace py = pybind11;
using namespace deformkit;

std::string shape_of(const py::array& a);

// An (n, 3) float32/float64 array, C-contiguous (copied only when the layout requires it).
py::array points_array(const py::handle& obj, const char* name);

py::array_t<double, py::array::c_style> as_double(const py::array& a);

int parse_axis(const py::object& axis, const char* name);

double finite_param(double v, const char* name);

// Real numbers only: forcecast would silently drop an imaginary part or call into objects.
void require_real(const py::object& obj, const char* name);

Frame parse_frame(const py::object& obj, const char* name);

std::pair<double, double> parse_range(const py::object& obj, const char* name);

std::vector<double> parse_vector(const py::object& obj, const char* name);

// A linear law offset + rate * clamp(z, limits), or a natural cubic spline through samples.
Profile parse_law(double offset, const std::optional<double>& rate, const py::object& limits,
                  const py::object& profile, const std::string& extend);

void apply_weights(Deformer& d, const py::object& weights);

enum class Output { Positions, Displacement };

// `out` checked (dtype, shape, layout, no partial overlap with `source`), or a new (rows, 3) array.
py::array output_array(const py::object& out, py::ssize_t rows, const py::dtype& dtype, const py::array* source);

py::array deform_or_displace(const Deformer& d, const py::object& points, const py::object& out, Output what);

py::array py_deform(const Deformer& d, const py::object& points, const py::object& out);

py::array py_displacement(const Deformer& d, const py::object& points, const py::object& out);

py::array cast_like(py::array_t<double> result, const py::array& like);

py::array py_jacobian(const Deformer& d, const py::object& points);

py::array py_normals(const Deformer& d, const py::object& points, const py::object& normals);

py::array py_volume_ratio(const Deformer& d, const py::object& points);

py::object weights_of(const Deformer& d);

// Polygons as a flat corner list and offsets (face f is corners[offsets[f] .. offsets[f + 1])).
struct Faces {
  std::vector<std::int64_t> corners, offsets;
};
// An (m, k) integer array, or a sequence of index sequences (polygons of mixed sizes).
Faces parse_faces(const py::object& faces);

// Bindings of the lattice family (lattice.cpp), the surface deformers (surface.cpp) and
// subdivision (subdivision.cpp).
void bind_lattice(py::module_& m);
void bind_surface(py::module_& m);
void bind_subdivision(py::module_& m);

}  // namespace deformkit_py
