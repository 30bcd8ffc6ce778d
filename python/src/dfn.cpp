// DFN instances from Python. One C++ class, Node, holds any DFI the registry creates; the
// classes users see (cdff.dfn.EdgeDetection...) are generated from the DFN descriptions by
// scripts/dfn_codegen.py as Python subclasses whose port properties come from input_port() and
// output_port() below. Parameters are keyword arguments, checked by the same C++ reader as YAML
// files (same messages, raised as cdff.InvalidParameterError); process() runs without the GIL.

#include <fmt/format.h>
#include <pybind11/stl.h>
#include <yaml-cpp/yaml.h>

#include "cdff/dfn/registry.hpp"
#include "common.hpp"

namespace cdff::python {
namespace {

/// Owns one DFI instance.
struct DfnHandle {
  std::unique_ptr<dfn::Node> node;
};

/// A node's inputs or outputs (`node.inputs`, `node.outputs`): the generated subclasses hold the
/// port properties, as C++'s `in` and `out` hold the ports.
struct Ports {
  py::object node;
};

/// The node a port property was read on: the node itself or its Ports.
DfnHandle& handleOf(py::handle self) {
  if (py::isinstance<DfnHandle>(self)) return self.cast<DfnHandle&>();
  return self.cast<Ports&>().node.cast<DfnHandle&>();
}

constexpr const char* kKeywordSource = "<Python keyword arguments>";

YAML::Node yamlOf(py::handle value, const std::string& key, const dfn::Node& node) {
  if (PyBool_Check(value.ptr())) return YAML::Node(value.cast<bool>());
  if (PyLong_Check(value.ptr())) return YAML::Node(value.cast<long long>());
  if (PyFloat_Check(value.ptr())) return YAML::Node(value.cast<double>());
  if (PyUnicode_Check(value.ptr())) return YAML::Node(value.cast<std::string>());
  if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value) ||
      py::hasattr(value, "__array__")) {
    YAML::Node list(YAML::NodeType::Sequence);
    for (py::handle item : py::iter(value)) {
      if (py::hasattr(item, "item")) item = item.attr("item")();  // NumPy scalars
      list.push_back(yamlOf(item, key, node));
    }
    return list;
  }
  throw py::type_error(fmt::format(
      "{} parameter '{}': a Python {} cannot be a parameter value; expected bool, int, float, "
      "str or a sequence of numbers",
      node.name(), key, py::str(py::type::of(value).attr("__name__")).cast<std::string>()));
}

void configure(DfnHandle& h, const py::dict& parameters) {
  YAML::Node map(YAML::NodeType::Map);
  for (auto [key, value] : parameters) {
    const std::string name = key.cast<std::string>();
    map[name] = yamlOf(value, name, *h.node);
  }
  check(h.node->configure(map, kKeywordSource));
}

py::object parameterValue(const YAML::Node& node, dfn::ParameterType type) {
  switch (type) {
    case dfn::ParameterType::kBool:
      return py::cast(node.as<bool>());
    case dfn::ParameterType::kInt:
      return py::cast(node.as<long long>());
    case dfn::ParameterType::kDouble:
      return py::cast(node.as<double>());
    case dfn::ParameterType::kString:
      return py::cast(node.as<std::string>());
    case dfn::ParameterType::kDoubleList:
      return py::cast(node.as<std::vector<double>>());
  }
  return py::none();
}

py::dict parameters(const DfnHandle& h) {
  const YAML::Node yaml = h.node->parametersAsYaml();
  py::dict out;
  for (const dfn::ParameterSpec& spec : h.node->implementation().parameters)
    if (yaml[spec.name]) out[spec.name.c_str()] = parameterValue(yaml[spec.name], spec.type);
  return out;
}

py::object portValue(const dfn::PortBase& port) {
  return toPython(port.anyValue());
}

template <typename Port>
Port& portOf(const DfnHandle& h, const std::string& name, bool input) {
  dfn::PortBase* port = input ? static_cast<dfn::PortBase*>(h.node->findInput(name))
                              : static_cast<dfn::PortBase*>(h.node->findOutput(name));
  if (!port)
    raise(notFound("{} has no {} port '{}'", h.node->name(), input ? "input" : "output", name));
  return static_cast<Port&>(*port);
}

void setInput(DfnHandle& h, const std::string& name, py::handle value) {
  auto& port = portOf<dfn::InputPortBase>(h, name, true);
  if (value.is_none()) {
    port.clear();
    return;
  }
  const Converter* c = findConverter(port.type());
  Value v = c ? c->from_python(value) : Value();
  if (v.empty())
    throw py::type_error(
        fmt::format("{} input '{}' takes a {} ({}); got a Python {}", h.node->name(), name,
                    c ? c->python_type : "value", port.type().name(),
                    py::str(py::type::of(value).attr("__qualname__")).cast<std::string>()));
  check(port.setAny(std::move(v)));
}

py::object property(py::cpp_function get, py::object set, const std::string& doc) {
  return py::module_::import("builtins").attr("property")(get, set, py::none(), doc);
}

void bindDiagnostics(py::module_& m) {
  py::class_<dfn::Diagnostics>(m, "Diagnostics", "A DFN instance's calls, faults and timings.")
      .def_property_readonly("last_status",
                             [](const dfn::Diagnostics& d) { return d.last_status.toString(); })
      .def_readonly("last_error", &dfn::Diagnostics::last_error)
      .def_property_readonly("warnings",
                             [](const dfn::Diagnostics& d) {
                               return std::vector<std::string>(d.warnings.begin(),
                                                               d.warnings.end());
                             })
      .def_readonly("warning_count", &dfn::Diagnostics::warning_count)
      .def_readonly("call_count", &dfn::Diagnostics::call_count)
      .def_readonly("error_count", &dfn::Diagnostics::error_count)
      .def_readonly("last_wall_s", &dfn::Diagnostics::last_wall_s)
      .def_readonly("max_wall_s", &dfn::Diagnostics::max_wall_s)
      .def_readonly("last_cpu_s", &dfn::Diagnostics::last_cpu_s)
      .def_property_readonly("mean_wall_s", &dfn::Diagnostics::meanWallSeconds)
      .def_property_readonly("mean_cpu_s", &dfn::Diagnostics::meanCpuSeconds);
}

void bindNode(py::module_& m) {
  py::class_<DfnHandle>(
      m, "Node",
      "One DFN implementation (DFI) instance. Use the generated classes of cdff.dfn "
      "(cdff.dfn.EdgeDetection('Canny', low_threshold=40)); Node(dfn, dfi, parameters) is "
      "what they call.")
      .def(py::init([](const std::string& dfn, const std::string& dfi, const py::dict& params) {
             auto h = std::make_unique<DfnHandle>();
             h->node = take(dfn::Registry::instance().create(dfn, dfi));
             if (!params.empty()) configure(*h, params);
             return h;
           }),
           py::arg("dfn"), py::arg("implementation"), py::arg("parameters") = py::dict())
      .def(
          "configure", [](DfnHandle& h, const py::kwargs& kw) { configure(h, kw); },
          "Sets parameters (keyword arguments, in the description's units: angles in degrees); "
          "the others take their defaults. On error the previous parameters stay.")
      .def(
          "process",
          [](DfnHandle& h) {
            Status s;
            {
              py::gil_scoped_release release;
              s = h.node->process();
            }
            check(s);
          },
          "Runs the DFI on its inputs (without the GIL: other Python threads run meanwhile).")
      .def_property_readonly("parameters", &parameters,
                             "The current parameters, in the description's units.")
      .def_property_readonly(
          "diagnostics", [](const DfnHandle& h) { return h.node->diagnostics(); },
          "A copy of the instance's diagnostics.")
      .def_property(
          "name", [](const DfnHandle& h) { return h.node->name(); },
          [](DfnHandle& h, std::string name) { h.node->setName(std::move(name)); })
      .def_property_readonly("dfn", [](const DfnHandle& h) { return h.node->description().name; })
      .def_property_readonly("implementation",
                             [](const DfnHandle& h) { return h.node->implementation().name; })
      .def("__repr__", [](const DfnHandle& h) {
        return fmt::format("<cdff.dfn.{} '{}' ({})>", h.node->description().name, h.node->name(),
                           h.node->implementation().name);
      });
}

}  // namespace

void bindDfn(py::module_& m) {
  bindDiagnostics(m);
  bindNode(m);
  py::class_<Ports>(m, "Ports", "A node's input or output ports, as properties.")
      .def(py::init([](py::object node) {
             if (!py::isinstance<DfnHandle>(node))
               throw py::type_error("Ports(node): node must be a cdff.dfn node");
             return Ports{std::move(node)};
           }),
           py::arg("node"))
      .def_property_readonly("node", [](const Ports& p) { return p.node; });
  m.def(
      "input_port",
      [](const std::string& name, const std::string& doc) {
        return property(py::cpp_function([name](py::handle self) {
                          return portValue(portOf<dfn::InputPortBase>(handleOf(self), name, true));
                        }),
                        py::cpp_function([name](py::handle self, py::handle value) {
                          setInput(handleOf(self), name, value);
                        }),
                        doc);
      },
      py::arg("name"), py::arg("doc"), "A property over a DFN's input port (for generated code).");
  m.def(
      "output_port",
      [](const std::string& name, const std::string& doc) {
        return property(
            py::cpp_function([name](py::handle self) {
              return portValue(portOf<dfn::OutputPortBase>(handleOf(self), name, false));
            }),
            py::none(), doc);
      },
      py::arg("name"), py::arg("doc"), "A read-only property over a DFN's output port.");
  m.def(
      "implementations", [] { return dfn::Registry::instance().implementations(); },
      "Every registered (DFN, DFI) pair.");
  m.def(
      "port_types",
      [](const std::string& dfn) {
        const dfn::DfnDescription* d = dfn::Registry::instance().findDescription(dfn);
        if (!d) raise(notFound("no DFN named '{}'", dfn));
        std::vector<std::tuple<std::string, std::string, std::string>> ports;
        for (const dfn::PortSpec& p : d->inputs) ports.emplace_back("input", p.name, p.type);
        for (const dfn::PortSpec& p : d->outputs) ports.emplace_back("output", p.name, p.type);
        return ports;
      },
      py::arg("dfn"), "(direction, name, type name) of each port of a DFN.");
}

}  // namespace cdff::python
