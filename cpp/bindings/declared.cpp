// The declared signatures and the call guard of declared.hpp.
#include "declared.hpp"

namespace deformkit_py {

std::vector<Declaration>& declarations() {
  static std::vector<Declaration> all;
  return all;
}

void publish_signatures(py::module_& m) {
  py::dict table;
  for (const Declaration& d : declarations()) {
    py::list parameters;
    for (const DeclaredParameter& p : d.parameters) {
      py::dict entry;
      entry["name"] = p.name;
      entry["kind"] = p.positional_only ? "positional_only" : p.keyword_only ? "keyword_only" : "positional";
      if (p.default_value) entry["default"] = p.default_value;
      entry["accepts"] = p.accepts();
      parameters.append(entry);
    }
    py::dict signature;
    signature["method"] = d.is_method;
    signature["parameters"] = parameters;
    const py::str key(d.scope.empty() ? d.name : d.scope + "." + d.name);
    // One signature a name: an overload would need _arguments.py to tell which one was meant.
    if (table.contains(key)) py::pybind11_fail("deformkit: " + std::string(key) + " is defined twice (overloads are not declared)");
    table[key] = signature;
  }
  declarations().clear();
  m.attr("_signatures") = table;
}

void throw_unnamed_allocation_failure(const std::string& title) {
  throw_memory_error(title + ": not enough memory for its working arrays (the C++ core's allocation failed)");
}

}  // namespace deformkit_py
