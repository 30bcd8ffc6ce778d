// Port values that are Python built-ins: float, int, bool, str, a JSON document (dict, list...),
// a Timestamp (int, µs), and the TrackState enumeration.

#include <limits>

#include <fmt/format.h>
#include <pybind11/stl.h>
#include <nlohmann/json.hpp>

#include "cdff/types/track_state.hpp"
#include "cdff/types/type_registry.hpp"
#include "common.hpp"

namespace cdff::python {
namespace {

bool isInt(py::handle h) {
  return PyLong_Check(h.ptr()) && !PyBool_Check(h.ptr());
}

template <typename T>
Value integerValue(py::handle h, const char* type_name) {
  if (!isInt(h)) return Value();
  long long v = 0;
  try {
    v = h.cast<long long>();
  } catch (const py::cast_error&) {
    v = std::numeric_limits<long long>::max();
  }
  if (v < std::numeric_limits<T>::min() || v > std::numeric_limits<T>::max())
    throw py::value_error(
        fmt::format("{} is out of range for a {} ([{}, {}])", py::repr(h).cast<std::string>(),
                    type_name, std::numeric_limits<T>::min(), std::numeric_limits<T>::max()));
  return Value::of<T>(static_cast<T>(v));
}

void addBuiltins() {
  addConverter("Double", {[](const Value& v) { return py::cast(*v.as<double>()); },
                          [](py::handle h) {
                            if (!PyFloat_Check(h.ptr()) && !isInt(h)) return Value();
                            return Value::of<double>(h.cast<double>());
                          },
                          "float"});
  addConverter("Int", {[](const Value& v) { return py::cast(*v.as<int>()); },
                       [](py::handle h) { return integerValue<int>(h, "Int (32-bit)"); }, "int"});
  addConverter(
      "Timestamp",
      {[](const Value& v) { return py::cast(*v.as<Timestamp>()); },
       [](py::handle h) { return integerValue<Timestamp>(h, "Timestamp (int64 µs)"); }, "int"});
  addConverter("Bool", {[](const Value& v) { return py::cast(*v.as<bool>()); },
                        [](py::handle h) {
                          if (!PyBool_Check(h.ptr())) return Value();
                          return Value::of<bool>(h.cast<bool>());
                        },
                        "bool"});
  addConverter("String", {[](const Value& v) { return py::cast(*v.as<std::string>()); },
                          [](py::handle h) {
                            if (!PyUnicode_Check(h.ptr())) return Value();
                            return Value::of<std::string>(h.cast<std::string>());
                          },
                          "str"});
  // JSON documents cross through their text: the exact JSON a recording holds.
  addConverter("Json",
               {[](const Value& v) {
                  return py::module_::import("json").attr("loads")(v.as<nlohmann::json>()->dump());
                },
                [](py::handle h) {
                  std::string text;
                  try {
                    text = py::module_::import("json")
                               .attr("dumps")(h, py::arg("allow_nan") = false)
                               .cast<std::string>();
                  } catch (py::error_already_set&) {
                    return Value();
                  }
                  return Value::of<nlohmann::json>(nlohmann::json::parse(text));
                },
                "dict | list | str | float | int | bool | None (JSON)"});
}

}  // namespace

void bindScalars(py::module_& m) {
  py::enum_<TrackState> track(m, "TrackState",
                              "The state of a track (UNINITIALISED, ACQUIRING, TRACKING, "
                              "DEGRADED, LOST).");
  for (TrackState s : allTrackStates()) track.value(std::string(toString(s)).c_str(), s);
  track.def("is_tracked", &isTracked, "TRACKING or DEGRADED: a frame that counts as tracked.");
  addConverter("TrackState", {[](const Value& v) { return py::cast(*v.as<TrackState>()); },
                              [](py::handle h) {
                                if (!py::isinstance<TrackState>(h)) return Value();
                                return Value::of<TrackState>(h.cast<TrackState>());
                              },
                              "cdff.TrackState"});
  addBuiltins();
  m.def(
      "type_names",
      [] {
        std::vector<std::string> names;
        for (TypeId t : allTypes()) names.emplace_back(t.name());
        return names;
      },
      "Every registered CDFF data type's name, in the type registry's order.");
  m.def(
      "python_type_of",
      [](const std::string& name) -> py::object {
        const Converter* c = findConverter(findType(name));
        if (!c) return py::none();
        return py::str(c->python_type);
      },
      py::arg("type_name"),
      "The Python type a registered type's values cross as ('cdff.Image', 'float'), or None "
      "when the binding has no conversion for it.");
}

}  // namespace cdff::python
