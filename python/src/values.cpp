// The converter table of port values and the conversion of any Python object to a Value, the
// owner that keeps NumPy arrays alive from C++, paths, and array descriptions for messages.

#include <map>

#include <fmt/format.h>

#include "cdff/types/type_registry.hpp"
#include "common.hpp"

namespace cdff::python {
namespace {
std::map<std::string, Converter, std::less<>>& converters() {
  static std::map<std::string, Converter, std::less<>> table;
  return table;
}
}  // namespace

void addConverter(std::string_view type_name, Converter converter) {
  converters()[std::string(type_name)] = std::move(converter);
}

const Converter* findConverter(TypeId type) {
  if (!type.valid()) return nullptr;
  auto it = converters().find(type.name());
  return it == converters().end() ? nullptr : &it->second;
}

std::shared_ptr<const void> keepAlive(py::handle object) {
  auto* kept = new py::object(py::reinterpret_borrow<py::object>(object));
  return std::shared_ptr<const void>(kept, [](const void* p) {
    // Released from whichever thread drops the last reference (a DFPC thread): take the GIL,
    // unless the interpreter is already gone.
    if (!Py_IsInitialized()) return;
    py::gil_scoped_acquire gil;
    delete static_cast<const py::object*>(p);
  });
}

std::string pathOf(py::handle path) {
  return py::module_::import("os").attr("fspath")(path).cast<std::string>();
}

std::string describeArray(const py::array& array) {
  std::string shape;
  for (py::ssize_t i = 0; i < array.ndim(); ++i)
    shape += (i ? ", " : "") + std::to_string(array.shape(i));
  if (array.ndim() == 1) shape += ",";
  return fmt::format("{} array of shape ({})", py::str(array.dtype()).cast<std::string>(), shape);
}

Value valueOf(py::handle object, const std::string& type_name, const std::string& what) {
  if (!type_name.empty()) {
    const TypeId type = findType(type_name);
    if (!type.valid())
      throw py::value_error(fmt::format("{}: no data type named '{}'; expected one of {}", what,
                                        type_name, typeNames()));
    const Converter* c = findConverter(type);
    Value v = c ? c->from_python(object) : Value();
    if (v.empty())
      throw py::type_error(
          fmt::format("{}: a Python {} is not a {} ({})", what,
                      py::str(py::type::of(object).attr("__qualname__")).cast<std::string>(),
                      type_name, c ? c->python_type : "no conversion"));
    return v;
  }
  // Classes first (they accept only their own instances), then the built-ins, most specific
  // first: bool before int, int before float, Json last (it takes any JSON-able object). The
  // converters are all added when the module loads, so the order is made once.
  static const std::vector<TypeId> order = [] {
    std::vector<TypeId> types;
    for (TypeId t : allTypes())
      if (const Converter* c = findConverter(t); c && c->python_type.rfind("cdff.", 0) == 0)
        types.push_back(t);
    for (const char* name : {"Bool", "Int", "Timestamp", "Double", "String", "Json"})
      types.push_back(findType(name));
    return types;
  }();
  for (TypeId t : order) {
    const Converter* c = findConverter(t);
    if (!c) continue;
    try {
      Value v = c->from_python(object);
      if (!v.empty()) return v;
    } catch (const py::value_error&) {
      // e.g. an int out of the Int range: the next type (Timestamp) may take it
    }
  }
  throw py::type_error(fmt::format(
      "{}: a Python {} is none of the CDFF data types; expected a cdff data type, a bool, int, "
      "float, str or a JSON-able object",
      what, py::str(py::type::of(object).attr("__qualname__")).cast<std::string>()));
}

py::object toPython(const Value& value) {
  if (value.empty()) return py::none();
  const Converter* c = findConverter(value.type());
  if (!c)
    raise(Status(StatusCode::kInternal,
                 fmt::format("a {} value and the Python binding has no conversion for that type",
                             value.type().name())));
  return c->to_python(value);
}

}  // namespace cdff::python
