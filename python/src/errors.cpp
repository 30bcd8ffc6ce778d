// cdff.Error and one subclass per StatusCode. Each also derives from the built-in exception a
// Python user would catch for that fault (ValueError for bad input or parameters, LookupError
// for a missing name, OSError for I/O), so that both `except cdff.Error` and `except ValueError`
// work.

#include <array>

#include "common.hpp"

namespace cdff::python {
namespace {

struct ErrorClass {
  StatusCode code;
  const char* name;
  PyObject* builtin;
  PyObject* type = nullptr;
};

std::array<ErrorClass, 9>& errorClasses() {
  static std::array<ErrorClass, 9> classes{{
      {StatusCode::kInvalidInput, "InvalidInputError", PyExc_ValueError},
      {StatusCode::kInvalidParameter, "InvalidParameterError", PyExc_ValueError},
      {StatusCode::kNotConfigured, "NotConfiguredError", PyExc_RuntimeError},
      {StatusCode::kNotFound, "NotFoundError", PyExc_LookupError},
      {StatusCode::kIoError, "IoError", PyExc_OSError},
      {StatusCode::kCorruptData, "CorruptDataError", PyExc_ValueError},
      {StatusCode::kNumericalFailure, "NumericalFailureError", PyExc_ArithmeticError},
      {StatusCode::kTimeout, "TimeoutError", PyExc_TimeoutError},
      {StatusCode::kInternal, "InternalError", PyExc_RuntimeError},
  }};
  return classes;
}

PyObject* g_error = nullptr;
PyObject* g_copy_warning = nullptr;

}  // namespace

void defineErrors(py::module_& m) {
  g_error = PyErr_NewExceptionWithDoc(
      "cdff.Error",
      "A CDFF call failed. `code` names the fault (e.g. 'invalid input'), `reason` says what "
      "went wrong with which value and what was expected, `location` is 'file:line:column' "
      "when the fault is in a file ('' otherwise); str() is the C++ Status message.",
      PyExc_Exception, nullptr);
  m.add_object("Error", py::handle(g_error));
  for (ErrorClass& c : errorClasses()) {
    py::tuple bases = py::make_tuple(py::handle(g_error), py::handle(c.builtin));
    const std::string qualified = std::string("cdff.") + c.name;
    c.type = PyErr_NewException(qualified.c_str(), bases.ptr(), nullptr);
    m.add_object(c.name, py::handle(c.type));
  }
  g_copy_warning = PyErr_NewExceptionWithDoc(
      "cdff.CopyWarning",
      "An array was copied because its memory layout cannot be shared with CDFF (the message "
      "says which layout would have been shared). Pass copy=True to copy without the warning.",
      PyExc_UserWarning, nullptr);
  m.add_object("CopyWarning", py::handle(g_copy_warning));
}

py::object errorOf(const Status& status) {
  PyObject* type = g_error;
  for (const ErrorClass& c : errorClasses())
    if (c.code == status.code()) type = c.type;
  py::object error = py::reinterpret_borrow<py::object>(type)(status.message());
  error.attr("code") = toString(status.code());
  error.attr("reason") = status.reason();
  error.attr("location") =
      status.location().prefix().empty()
          ? std::string()
          : status.location().prefix().substr(0, status.location().prefix().size() - 2);
  return error;
}

void raise(const Status& status) {
  py::object error = errorOf(status);
  PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(error.ptr())), error.ptr());
  throw py::error_already_set();
}

void warnCopy(const std::string& what) {
  if (PyErr_WarnEx(g_copy_warning, what.c_str(), 1) != 0) throw py::error_already_set();
}

}  // namespace cdff::python
