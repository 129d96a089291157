// error_code -> Python exception: tether/_errors.py picks the class from the error's category (the codecs'
// classes, defined by their plugins through `register_errors`, or the library's own) and condition.
#include <boost/asio/error.hpp>
#include <boost/system/error_code.hpp>

#include <pybind11/stl.h>

#include "binding.hpp"
#include "tether/transports/transport_error.hpp"

namespace tether::python {

py::object error_object(const boost::system::error_code& error, const std::string& message,
                        const std::string& path) {
  py::module_ errors = py::module_::import("tether._errors");
  const std::string text = message.empty() ? error.message() : message;
  if (error == boost::asio::error::operation_aborted) {
    return errors.attr("ClosedError")("the client was closed before the operation completed");
  }
  if (error == transports::TransportError::disconnected) {
    return errors.attr("DisconnectedError")(error.value(), text);
  }
  const bool timeout = error == boost::system::errc::timed_out;
  py::object tether_error = errors.attr("make_error")(error.category().name(), error.value(), text, timeout);
  if (tether_error.is_none()) {
    // OS errors (and asio's, which are errno values): OSError picks the subclass from errno.
    if (error == boost::asio::error::eof) {
      return py::module_::import("builtins").attr("ConnectionError")("the link closed (end of file)");
    }
    py::object builtins = py::module_::import("builtins");
    if (timeout) return builtins.attr("TimeoutError")(error.value(), text);
    // A name that does not resolve: what Python's own socket functions raise. Its codes are no errno values
    // (netdb's 1, host not found, would make OSError a PermissionError).
    if (error.category() == boost::asio::error::get_netdb_category() ||
        error.category() == boost::asio::error::get_addrinfo_category()) {
      return py::module_::import("socket").attr("gaierror")(error.value(), text);
    }
    // Other non-errno categories (asio's misc): an OSError without an errno, so no subclass is guessed.
    if (error.category() != boost::system::system_category() && error.category() != boost::system::generic_category()) {
      return builtins.attr("OSError")(text);
    }
    if (path.empty()) return builtins.attr("OSError")(error.value(), text);
    return builtins.attr("OSError")(error.value(), text, path);
  }
  return tether_error;
}

void register_errors(py::module_& submodule, const ErrorFamily& family) {
  const auto spec = [](const ExceptionClass& c) -> py::object {
    if (c.name == nullptr) return py::none();
    return py::make_tuple(c.name, c.doc);
  };
  py::list more;
  for (const ExceptionClass& c : family.more) more.append(spec(c));
  py::module_::import("tether._errors")
      .attr("define_family")(submodule, family.category, spec(family.base), spec(family.timeout),
                             spec(family.rejected), py::cast(family.rejected_codes), more);
}

void raise_error(const boost::system::error_code& error, const std::string& message, const std::string& path) {
  py::object exception = error_object(error, message, path);
  PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(exception.ptr())), exception.ptr());
  throw py::error_already_set();
}

void raise_inherited(const char* what) {
  py::object exception = py::module_::import("tether._errors")
                             .attr("ClosedError")(std::string(what) +
                                                  " was opened before this process was forked: its I/O thread "
                                                  "stayed with the parent; open a new one in this process");
  PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(exception.ptr())), exception.ptr());
  throw py::error_already_set();
}

void raise_closed(const char* what) {
  py::object exception = py::module_::import("tether._errors").attr("ClosedError")(std::string(what) + " is closed");
  PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(exception.ptr())), exception.ptr());
  throw py::error_already_set();
}

}  // namespace tether::python
