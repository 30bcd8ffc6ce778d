// The converter table of port values, the owner that keeps NumPy arrays alive from C++, and
// array descriptions for messages.

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

std::string describeArray(const py::array& array) {
  std::string shape;
  for (py::ssize_t i = 0; i < array.ndim(); ++i)
    shape += (i ? ", " : "") + std::to_string(array.shape(i));
  if (array.ndim() == 1) shape += ",";
  return fmt::format("{} array of shape ({})", py::str(array.dtype()).cast<std::string>(), shape);
}

}  // namespace cdff::python
