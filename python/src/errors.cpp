// error_code -> Python exception: the classes live in tether/_errors.py (plain Python, with `code` and
// `message`); this file picks one from the error's category and condition.
#include <boost/asio/error.hpp>
#include <boost/system/error_code.hpp>

#include <cstring>

#include "binding.hpp"

namespace tether::python {

namespace {
// The codec (or library) an error category belongs to: the exception family in tether._errors.
const char* family_of(const boost::system::error_category& category) {
  const char* name = category.name();
  if (std::strncmp(name, "tether.romi", 11) == 0) return "romi";
  if (std::strncmp(name, "tether.proxy", 12) == 0) return "proxy";
  if (std::strncmp(name, "tether.elcano", 13) == 0) return "elcano";
  if (std::strncmp(name, "tether.devices", 14) == 0) return "config";
  if (std::strncmp(name, "tether.", 7) == 0) return "transport";
  return nullptr;
}
}  // namespace

py::object error_object(const boost::system::error_code& error, const std::string& message,
                        const std::string& path) {
  py::module_ errors = py::module_::import("tether._errors");
  const std::string text = message.empty() ? error.message() : message;
  if (error == boost::asio::error::operation_aborted) {
    return errors.attr("ClosedError")("the client was closed before the operation completed");
  }
  const char* family = family_of(error.category());
  const bool timeout = error == boost::system::errc::timed_out;
  if (family == nullptr) {
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
  return errors.attr("make_error")(family, error.value(), text, timeout);
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
