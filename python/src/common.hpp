#pragma once
// Shared by the binding's translation units: errors raised as Python exceptions, NumPy arrays
// that view CDFF buffers (and buffers that view NumPy arrays), and the table that converts a
// port's Value to a Python object and back.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "cdff/types/buffer.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/type_registry.hpp"
#include "cdff/types/value.hpp"

namespace cdff::python {

namespace py = pybind11;

// ---- Errors -------------------------------------------------------------------------------

/// Creates cdff.Error and its subclasses (one per StatusCode) and cdff.CopyWarning in `m`.
void defineErrors(py::module_& m);
/// Raises the Python exception of `status`'s code with status.message() as its text (the same
/// text as the C++ error) and `code`/`reason`/`location` attributes. Only for non-OK statuses.
[[noreturn]] void raise(const Status& status);
/// The exception object raise() would raise, not raised (for callbacks that receive errors).
py::object errorOf(const Status& status);
/// Raises `status` when it is not OK.
inline void check(const Status& status) {
  if (!status.isOk()) raise(status);
}
template <typename T>
T take(Result<T>&& result) {
  if (!result.isOk()) raise(result.status());
  return std::move(result).value();
}
/// Issues a cdff.CopyWarning (a UserWarning) saying that `what` was copied and why.
void warnCopy(const std::string& what);

// ---- NumPy views ----------------------------------------------------------------------------

/// A read-only NumPy array over `data` (shape and byte strides given) that keeps `owner` alive.
template <typename T>
py::array readOnlyView(const std::shared_ptr<const void>& owner, const T* data,
                       std::vector<py::ssize_t> shape, std::vector<py::ssize_t> strides) {
  auto* keep = new std::shared_ptr<const void>(owner);
  py::capsule base(keep, [](void* p) { delete static_cast<std::shared_ptr<const void>*>(p); });
  py::array array(py::dtype::of<T>(), std::move(shape), std::move(strides), data, base);
  py::detail::array_proxy(array.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return array;
}

/// An owner that keeps a Python object alive from C++ and releases it with the GIL held, so that
/// a Buffer may view a NumPy array's memory from any thread.
std::shared_ptr<const void> keepAlive(py::handle object);

/// A Buffer<T> viewing `data` (count elements), kept alive by `object`.
template <typename T>
Buffer<T> viewOf(py::handle object, const void* data, std::size_t count) {
  return Buffer<T>::view(std::const_pointer_cast<void>(keepAlive(object)),
                         static_cast<const T*>(data), count);
}

/// A file path from a str or an os.PathLike (pathlib.Path).
std::string pathOf(py::handle path);

/// "float64 array of shape (3, 2)" for messages.
std::string describeArray(const py::array& array);

// ---- Port values ----------------------------------------------------------------------------

/// How the values of one registered type cross into Python and back. from_python returns an
/// empty Value when the object is not of the type (the caller raises the TypeError that names
/// the port), and raises itself when it is of the type but invalid.
struct Converter {
  std::function<py::object(const Value&)> to_python;
  std::function<Value(py::handle)> from_python;
  std::string python_type;  // "cdff.Image", "float", for messages and stubs
};

void addConverter(std::string_view type_name, Converter converter);
/// The converter of `type`, or null when the binding has none (a test walks the registry).
const Converter* findConverter(TypeId type);

/// A converter for a type bound as a py::class_<T, std::shared_ptr<T>>: values cross by copying
/// the struct, whose large arrays are shared Buffers (a header copy, no pixel or point copy), so
/// that a Python object never aliases a value another DFN holds.
template <typename T>
void addClassConverter(const std::string& python_type) {
  addConverter(TypeTraits<T>::name,
               {[](const Value& v) { return py::cast(std::make_shared<T>(*v.as<T>())); },
                [](py::handle h) {
                  if (!py::isinstance<T>(h)) return Value();
                  return Value::of<T>(std::make_shared<const T>(h.cast<const T&>()));
                },
                python_type});
}

// ---- Parts of the module --------------------------------------------------------------------

void bindImages(py::module_& m);
void bindClouds(py::module_& m);
void bindGeometry(py::module_& m);
void bindScalars(py::module_& m);
void bindFeatures(py::module_& m);
void bindModels(py::module_& m);
void bindDfn(py::module_& m);
void bindIo(py::module_& m);
void bindSimAndEval(py::module_& m);
void bindDfpc(py::module_& m);

/// The Value of a Python object: of the registered type `type_name` when given, else of the
/// first type (in the registry's order, classes before built-ins) whose converter takes it. A
/// TypeError names what was given and what is accepted.
Value valueOf(py::handle object, const std::string& type_name, const std::string& what);
/// The Python object of a Value (None when empty); an internal error for a type without a
/// converter.
py::object toPython(const Value& value);

}  // namespace cdff::python
