// tether.rpc: the schema codec's client (rpc::Client) with requests and replies as python3-protobuf messages
// of the schema's own types, made at run time from the schema the C++ client read (no generated Python).
#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/message.h>
#include <pybind11/stl.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "binding.hpp"
#include "tether/rpc/plugin.hpp"
#include "rover_holder.hpp"
#include "tether/rpc/client.hpp"
#include "virtual_board.hpp"

namespace tether::python {

namespace {

namespace pb = google::protobuf;

// The schema's files, dependencies first, serialized: what a Python descriptor pool is built from.
void collect_files(const pb::FileDescriptor& file, std::set<std::string>& seen, py::list& out) {
  if (!seen.insert(file.name()).second) return;
  for (int i = 0; i < file.dependency_count(); ++i) collect_files(*file.dependency(i), seen, out);
  pb::FileDescriptorProto proto;
  file.CopyTo(&proto);
  out.append(py::bytes(proto.SerializeAsString()));
}

// The Python message classes of a schema, one pool per schema hash (clients of one schema share classes, so
// a reply of one is an instance of the class another hands out).
py::object message_classes(const rpc::Schema& schema) {
  static py::dict* pools = new py::dict();  // leaked: lives as long as the interpreter's module
  const py::int_ key(schema.hash());
  if (pools->contains(key)) return (*pools)[key];
  py::object pool = py::module_::import("google.protobuf.descriptor_pool").attr("DescriptorPool")();
  std::set<std::string> seen;
  py::list files;
  collect_files(*schema.service().file(), seen, files);
  for (py::handle file : files) pool.attr("AddSerializedFile")(file);
  py::module_ factory = py::module_::import("google.protobuf.message_factory");
  py::dict classes;
  const auto class_of = [&](const pb::Descriptor& type) -> py::object {
    py::object descriptor = pool.attr("FindMessageTypeByName")(type.full_name());
    if (py::hasattr(factory, "GetMessageClass")) return factory.attr("GetMessageClass")(descriptor);
    return factory.attr("MessageFactory")(pool).attr("GetPrototype")(descriptor);  // python3-protobuf < 4.22
  };
  for (const rpc::Method& method : schema.methods()) {
    classes[py::str(method.input->full_name())] = class_of(*method.input);
    classes[py::str(method.output->full_name())] = class_of(*method.output);
  }
  py::object entry = py::make_tuple(pool, classes);
  (*pools)[key] = entry;
  return entry;
}

py::object class_of(const rpc::Schema& schema, const pb::Descriptor& type) {
  return message_classes(schema)[py::int_(1)][py::str(type.full_name())];
}

/// `tether.rpc.Client`.
struct RpcClient : ClientHolder<rpc::Client> {
  rpc::Client& get() { return ClientHolder::get("the rpc client"); }
};

const rpc::Method& method_of(const rpc::Client& client, const std::string& name) {
  const rpc::Method* method = client.schema().find(name);
  if (method == nullptr) {
    std::string known;
    for (const rpc::Method& m : client.schema().methods()) known += (known.empty() ? "" : ", ") + m.name;
    py::object error = py::module_::import("tether.rpc").attr("RpcRequestError")(
        static_cast<int>(rpc::RpcError::unknown_method),
        client.schema().file().filename().string() + " has no method " + name + " (it has " + known + ")");
    error.attr("text") = error.attr("message");
    PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(error.ptr())), error.ptr());
    throw py::error_already_set();
  }
  return *method;
}

// The request as the C++ client takes it: a message of the method's input type from a message of that class,
// a dict, or keyword arguments (python3-protobuf raises ValueError/TypeError for unknown fields and bad
// values, before anything is sent).
std::shared_ptr<pb::Message> request_of(const rpc::Client& client, const rpc::Method& method, py::handle request,
                                        const py::kwargs& fields) {
  py::object cls = class_of(client.schema(), *method.input);
  py::object message;
  if (request.is_none()) {
    message = cls(**fields);
  } else if (py::isinstance<py::dict>(request)) {
    if (py::len(fields) != 0) throw py::type_error("give the request as a dict or as keyword arguments, not both");
    message = cls(**request.cast<py::dict>());
  } else if (py::isinstance(request, cls)) {
    if (py::len(fields) != 0) throw py::type_error("give the request as a message or as keyword arguments, not both");
    message = py::reinterpret_borrow<py::object>(request);
  } else {
    throw py::type_error(method.name + " takes a " + method.input->full_name() + " (a message, a dict or keyword "
                         "arguments), got " + py::str(py::type::of(request).attr("__name__")).cast<std::string>());
  }
  const std::string bytes = message.attr("SerializeToString")().cast<std::string>();
  std::shared_ptr<pb::Message> parsed = client.new_request(method.name);
  if (!parsed->ParseFromString(bytes)) throw py::value_error("the request does not encode as " + method.input->full_name());
  return parsed;
}

// The exception of a failed call or stream: the device's answer as RpcDeviceError (its code and text), the
// rest as raise_error would (RpcTimeoutError, RpcRequestError, ...); every rpc exception has a `text`.
py::object failure_of(const rpc::error_code& error, const rpc::DeviceError& device_error, const std::string& method) {
  if (error == rpc::RpcError::device_error || error == rpc::RpcError::refused) {
    const rpc::CallError described(error, method, device_error);
    py::object exception = py::module_::import("tether.rpc").attr("RpcDeviceError")(
        static_cast<int>(device_error.code), std::string(described.what()));
    exception.attr("text") = device_error.text;
    exception.attr("refused") = error == rpc::RpcError::refused;
    return exception;
  }
  py::object exception = error_object(error, method.empty() ? std::string() : method + ": " + error.message());
  if (py::hasattr(exception, "message")) exception.attr("text") = exception.attr("message");
  return exception;
}

[[noreturn]] void raise_failure(const rpc::error_code& error, const rpc::DeviceError& device_error,
                                const std::string& method) {
  py::object exception = failure_of(error, device_error, method);
  PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(exception.ptr())), exception.ptr());
  throw py::error_already_set();
}

py::object reply_of(const rpc::Client& client, const rpc::Method& method, const pb::Message& reply) {
  return class_of(client.schema(), *method.output).attr("FromString")(py::bytes(reply.SerializeAsString()));
}

py::object event_to_python(const rpc::Event& event) {
  py::object make = py::module_::import("types").attr("SimpleNamespace");
  return std::visit(
      [&](const auto& e) -> py::object {
        using E = std::decay_t<decltype(e)>;
        if constexpr (std::is_same_v<E, rpc::events::SessionEstablished>) {
          return make("kind"_a = "session_established", "session_id"_a = e.session_id,
                      "streams_reopened"_a = e.streams_reopened, "first"_a = e.first);
        } else if constexpr (std::is_same_v<E, rpc::events::ResetDetected>) {
          return make("kind"_a = "reset_detected", "previous_session_id"_a = e.previous,
                      "reported_session_id"_a = e.current);
        } else if constexpr (std::is_same_v<E, rpc::events::SchemaMismatch>) {
          return make("kind"_a = "schema_mismatch", "device_hash"_a = e.device_hash, "schema_hash"_a = e.schema_hash,
                      "text"_a = e.text);
        } else if constexpr (std::is_same_v<E, rpc::events::DeviceErrorReport>) {
          return make("kind"_a = "device_error", "code"_a = e.error.code, "text"_a = e.error.text);
        } else {
          return make("kind"_a = "link_failed", "error"_a = e.error.message());
        }
      },
      event);
}

rpc::Client::EventHandler python_handler(py::object callback) {
  return [handler = PyCallback(std::move(callback))](const rpc::Event& event) {
    if (interpreter_exiting()) return;
    py::gil_scoped_acquire gil;
    handler(event_to_python(event));
  };
}

std::chrono::milliseconds milliseconds_of(double seconds, const char* name, double low, double high) {
  if (!(seconds >= low) || seconds > high) {
    throw py::value_error(std::string(name) + " must be " + std::to_string(low) + " <= t <= " + std::to_string(high) +
                          " s");
  }
  return std::chrono::milliseconds(std::lround(seconds * 1000.0));
}

// What a stream's handler (on the io thread) hands to the Python iterator: bounded, oldest dropped first.
struct StreamQueue {
  static constexpr std::size_t kCapacity = 256;
  std::mutex mutex;
  std::condition_variable changed;
  std::deque<std::pair<std::string, std::uint32_t>> messages;  // serialized message, seq
  std::optional<rpc::error_code> end;
  rpc::DeviceError end_error;
  std::uint64_t dropped = 0;
};

/// `tether.rpc.Stream`: an open stream as an iterator of messages.
struct RpcStream {
  std::shared_ptr<RpcClient> owner;
  std::string method;
  py::object message_class;
  rpc::Stream stream;
  std::shared_ptr<StreamQueue> queue;
  std::optional<std::uint64_t> remaining;  // messages still to deliver (count), or forever
  std::chrono::milliseconds timeout{0};    // longest wait for the next message
  std::uint32_t last_seq = 0;

  void close() {
    py::gil_scoped_release release;
    stream.close();
  }

  py::object next() {
    if (remaining && *remaining == 0) {
      close();
      throw py::stop_iteration();
    }
    std::optional<std::pair<std::string, std::uint32_t>> message;
    std::optional<rpc::error_code> end;
    rpc::DeviceError end_error;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      {
        py::gil_scoped_release release;
        std::unique_lock lock(queue->mutex);
        const auto until = std::min(deadline, std::chrono::steady_clock::now() + std::chrono::milliseconds(100));
        queue->changed.wait_until(lock, until, [&] { return !queue->messages.empty() || queue->end.has_value(); });
        if (!queue->messages.empty()) {
          message = std::move(queue->messages.front());
          queue->messages.pop_front();
        } else if (queue->end) {
          end = queue->end;
          end_error = queue->end_error;
        }
      }
      if (message || end) break;
      if (PyErr_CheckSignals() != 0) {
        close();
        throw py::error_already_set();
      }
      if (std::chrono::steady_clock::now() >= deadline) {
        close();
        raise_failure(rpc::make_error_code(rpc::RpcError::timed_out), {},
                      method + ": no stream message within " + std::to_string(timeout.count()) + " ms; stream");
      }
    }
    if (end) {
      if (*end == boost::asio::error::operation_aborted && !stream.is_open()) throw py::stop_iteration();
      raise_failure(*end, end_error, method);
    }
    if (remaining) --*remaining;
    last_seq = message->second;
    return message_class.attr("FromString")(py::bytes(message->first));
  }
};

}  // namespace

void register_rpc(py::module_& parent);

void register_rpc(py::module_& parent) {
  rover_class(parent).def(
      "rpc",
      [](const std::shared_ptr<RoverHolder>& holder, const std::string& device) {
        return client_of<RpcClient>(holder, device, [](devices::Rover& rover, const std::string& n) {
          return rover.client<rpc::Client>(n);
        });
      },
      py::arg("name"), "The client of the rpc device ``name``.");

  py::module_ module = parent.def_submodule(
      "rpc", "The schema codec: a device's methods from a proto3 service, with the schema's own messages.");
  register_errors(module, {"tether.rpc",
                           {"RpcError", "An rpc call or stream failed: ``code`` (the client's ``RpcError`` value: "
                                        "3 schema_mismatch, 10 device_reset, 11 bad_reply, ...; a device's own "
                                        "code in ``RpcDeviceError``), ``message`` and ``text``."},
                           {"RpcTimeoutError", "No answer within the call budget (8 timed_out), not sent within the "
                                               "queue timeout (9 queue_timeout), or no stream message in time."},
                           {"RpcRequestError", "Rejected before anything was written: 4 unknown_method, 5 wrong_kind "
                                               "(a call to a stream or the reverse), 6 invalid_request, "
                                               "7 request_too_large."},
                           {static_cast<int>(rpc::RpcError::unknown_method), static_cast<int>(rpc::RpcError::wrong_kind),
                            static_cast<int>(rpc::RpcError::invalid_request),
                            static_cast<int>(rpc::RpcError::request_too_large)},
                           {{"RpcDeviceError", "The device answered with an error: ``code`` and ``text`` are the "
                                               "handler's ``Status::error(code, text)`` (1..0xFEFF), or, with "
                                               "``refused`` true, Tether's device runtime's refusal (0xFF01 "
                                               "unknown_method ... 0xFF0A streams_full)."}}});

  py::class_<rpc::Counters>(module, "Counters", "What an rpc client counted (a snapshot; they only grow).")
      .def_readonly("link", &rpc::Counters::link, "Decoder and engine (stale acks, retries, timeouts, resets).")
      .def_readonly("messages_sent", &rpc::Counters::messages_sent, "Calls, stream opens and closes (first sends).")
      .def_readonly("replies", &rpc::Counters::replies, "Calls answered with a reply.")
      .def_readonly("device_errors", &rpc::Counters::device_errors, "Calls and streams answered with a handler's error.")
      .def_readonly("refusals", &rpc::Counters::refusals, "Messages the device runtime refused.")
      .def_readonly("stream_messages", &rpc::Counters::stream_messages, "Stream messages delivered.")
      .def_readonly("stale_stream_messages", &rpc::Counters::stale_stream_messages,
                    "Stream messages of no open stream (dropped).")
      .def_readonly("pings_sent", &rpc::Counters::pings_sent, "Pings.")
      .def_readonly("hellos_sent", &rpc::Counters::hellos_sent, "Hellos.")
      .def_readonly("undecodable", &rpc::Counters::undecodable, "Checked frames that were no DeviceMessage.");

  py::class_<RpcStream, std::shared_ptr<RpcStream>>(module, "Stream", R"doc(An open stream (``client.stream(...)``):
iterate it for the method's messages, in order. The iteration ends after ``count`` messages (the stream is
then closed); it raises ``RpcDeviceError`` when the device ends the stream with an error and
``RpcTimeoutError`` when no message came within ``timeout``. ``close()`` (or leaving the ``with`` block)
stops it. Messages that arrive while nobody iterates wait in a queue of 256 (the oldest dropped first:
``dropped``).)doc")
      .def("__iter__", [](py::object self) { return self; })
      .def("__next__", &RpcStream::next)
      .def_property_readonly("method", [](const RpcStream& s) { return s.method; }, "The streaming method.")
      .def_property_readonly("seq", [](const RpcStream& s) { return s.last_seq; },
                             "The device's number of the last message returned (from 0 each time the device "
                             "opened the stream).")
      .def_property_readonly("dropped", [](const RpcStream& s) {
        const std::lock_guard lock(s.queue->mutex);
        return s.queue->dropped;
      }, "Messages dropped because the queue was full.")
      .def_property_readonly("is_open", [](const RpcStream& s) { return s.stream.is_open(); },
                             "True until ``close()`` or the stream's end.")
      .def("close", &RpcStream::close, "Stops the stream (the device is told). Idempotent.")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](RpcStream& self, py::args) { self.close(); });

  py::class_<RpcClient, std::shared_ptr<RpcClient>>(module, "Client", R"doc(Client of a device built from the proto3
schema ``schema`` (rpc::Client): ``call('MoveJoint', joint=2, angle_cdeg=-4500)`` returns the reply, a
python3-protobuf message of the method's output type (attribute access, ``MessageToDict``); requests are
keyword arguments, a dict or a message of the input type (``request_type(method)``). The schema is read at
run time; the device must have been built from the same one (the hashes are compared at open).

Calls wait for the device's session (queued for at most ``queue_timeout``), are acked, re-sent on loss and
run once; after a device reset, open streams are opened again by the client. Errors: ``RpcDeviceError``
(the device's ``code`` and ``text``), ``RpcTimeoutError``, ``RpcRequestError`` (before sending),
``RpcError`` (a schema mismatch, a device reset during the call), ``ClosedError``. Events go to
``on_event(event)`` on the io thread (``kind``: session_established, reset_detected, schema_mismatch,
device_error, link_failed). On a ``tether.VirtualUno`` or with ``clock=board.clock``, deadlines run on the
board's simulated time.)doc")
      .def(py::init([](py::object port, const std::string& schema_path, std::vector<std::string> import_paths,
                       std::optional<std::string> service, std::optional<unsigned> baud, double boot_wait,
                       double call_budget, double queue_timeout, std::optional<std::uint32_t> first_message_id,
                       py::object on_event, py::object clock, std::optional<std::string> boot, py::object record) {
             check_path(schema_path, "schema");
             rpc::SchemaOptions schema_options;
             for (const std::string& path : import_paths) schema_options.import_paths.emplace_back(path);
             if (service) schema_options.service = *service;
             std::optional<rpc::Schema> schema;
             try {
               schema.emplace(rpc::Schema::load(schema_path, schema_options));
             } catch (const rpc::SchemaError& failure) {
               throw py::value_error(failure.what());
             }
             rpc::Options options;
             if (baud) {
               if (*baud == 0) throw py::value_error("baud must be > 0");
               options.timing.baud = *baud;
             }
             options.timing.call_budget = static_cast<Duration>(milliseconds_of(call_budget, "call_budget", 0.001, 3600.0).count());
             options.timing.queue_timeout = static_cast<Duration>(milliseconds_of(queue_timeout, "queue_timeout", 0.0, 3600.0).count());
             options.first_message_id = first_message_id;
             std::shared_ptr<VirtualBoard> chosen = board_of_clock(clock);
             Transport transport = take_stream(port, SerialArguments{options.timing.baud, boot_wait, {}, true, 0, boot, rpc::boot_signature()});
             record_transport(transport, record, "rpc");
             const std::shared_ptr<VirtualBoard> board = deadline_board(std::move(chosen), transport);
             options.clock = link_clock(board);
             auto wrapper = std::make_shared<RpcClient>();
             wrapper->io = transport.io;
             rpc::Client::EventHandler handler;
             if (!on_event.is_none()) handler = python_handler(on_event);
             wrapper->client = std::make_shared<rpc::Client>(transport.stream, std::move(*schema), options, std::move(handler));
             wrapper->owner = join_board(board, wrapper->client, transport.keep_alive);
             return wrapper;
           }),
           py::arg("port_or_transport"), py::arg("schema"), py::kw_only(),
           py::arg("import_paths") = std::vector<std::string>(), py::arg("service") = py::none(),
           py::arg("baud") = py::none(), py::arg("boot_wait") = 2.0, py::arg("call_budget") = 2.0,
           py::arg("queue_timeout") = 10.0, py::arg("first_message_id") = py::none(),
           py::arg("on_event") = py::none(), py::arg("clock") = py::none(), py::arg("boot") = py::none(), py::arg("record") = py::none())
      .def_property_readonly("methods", [](RpcClient& self) {
        py::list names;
        for (const rpc::Method& m : self.get().schema().methods()) names.append(m.name);
        return names;
      }, "The service's methods, in wire order.")
      .def_property_readonly("schema_hash", [](RpcClient& self) { return self.get().schema().hash(); },
                             "The schema's hash (what the device must send).")
      .def("request_type", [](RpcClient& self, const std::string& method) {
        rpc::Client& client = self.get();
        return class_of(client.schema(), *method_of(client, method).input);
      }, py::arg("method"), "The message class of ``method``'s requests.")
      .def("reply_type", [](RpcClient& self, const std::string& method) {
        rpc::Client& client = self.get();
        return class_of(client.schema(), *method_of(client, method).output);
      }, py::arg("method"), "The message class of ``method``'s replies (or stream messages).")
      .def(
          "wait_ready",
          [](RpcClient& self) {
            rpc::Client& client = self.get();
            auto [error, session] = wait_interruptibly<rpc::error_code, std::uint32_t>(
                client.get_executor(), [&](client::CancellationSignal cancel, auto handler) {
                  client.async_wait_ready(client::bind_cancellation(std::move(cancel), std::move(handler)));
                });
            if (error == rpc::RpcError::schema_mismatch) {
              // A mismatch is only known from a DeviceHello, whose hash the session holds.
              const std::string text = rpc::mismatch_text(client.schema(), client.session().device_hash.value_or(0));
              py::object exception = py::module_::import("tether.rpc").attr("RpcError")(error.value(), text);
              exception.attr("text") = text;
              PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(exception.ptr())), exception.ptr());
              throw py::error_already_set();
            }
            if (error) raise_failure(error, {}, "");
            return session;
          },
          "Waits until the device answered with the same schema; returns its session id. Raises RpcError "
          "(code 3) naming both hashes when the device was built from another schema.")
      .def(
          "call",
          [](RpcClient& self, const std::string& name, py::object request, const py::kwargs& fields) {
            rpc::Client& client = self.get();
            const rpc::Method& method = method_of(client, name);
            if (method.streaming) {
              raise_failure(rpc::make_error_code(rpc::RpcError::wrong_kind), {},
                            name + " streams (use stream())");
            }
            const std::shared_ptr<pb::Message> message = request_of(client, method, request, fields);
            auto [error, result] = wait_interruptibly<rpc::error_code, rpc::CallResult>(
                client.get_executor(), [&](client::CancellationSignal cancel, auto handler) {
                  client.async_call(name, *message, client::bind_cancellation(std::move(cancel), std::move(handler)));
                });
            if (error) raise_failure(error, result.device_error, name);
            return reply_of(client, method, *result.reply);
          },
          py::arg("method"), py::arg("request") = py::none(),
          "Calls ``method`` with the request (keyword arguments, a dict or a message) and returns the reply. "
          "Blocks (Ctrl-C cancels the call).")
      .def(
          "call_async",
          [](const std::shared_ptr<RpcClient>& self, const std::string& name, py::object request,
             const py::kwargs& fields) {
            rpc::Client& client = self->get();
            const rpc::Method& method = method_of(client, name);
            if (method.streaming) {
              raise_failure(rpc::make_error_code(rpc::RpcError::wrong_kind), {}, name + " streams (use stream())");
            }
            const std::shared_ptr<pb::Message> message = request_of(client, method, request, fields);
            return asyncio_future([&](PyCallback settle, client::CancellationSignal cancel) {
              client.async_call(name, *message,
                                client::bind_cancellation(std::move(cancel), [self, settle, name, &method](
                                                                                 rpc::error_code error,
                                                                                 rpc::CallResult result) {
                                  if (interpreter_exiting()) return;
                                  py::gil_scoped_acquire gil;
                                  if (error || !self->client) {
                                    settle(failure_of(error, result.device_error, name), py::none());
                                  } else {
                                    settle(py::none(), reply_of(*self->client, method, *result.reply));
                                  }
                                }));
            });
          },
          py::arg("method"), py::arg("request") = py::none(),
          "``call`` for asyncio: a future of the running loop (cancelling it cancels the call).")
      .def(
          "stream",
          [](const std::shared_ptr<RpcClient>& self, const std::string& name, py::object request, double period,
             std::optional<std::uint64_t> count, std::optional<double> timeout, const py::kwargs& fields) {
            rpc::Client& client = self->get();
            const rpc::Method& method = method_of(client, name);
            if (!method.streaming) {
              raise_failure(rpc::make_error_code(rpc::RpcError::wrong_kind), {}, name + " is unary (use call())");
            }
            const auto period_ms = milliseconds_of(period, "period", 0.001, 65.535);
            const auto wait = timeout ? milliseconds_of(*timeout, "timeout", 0.001, 3600.0)
                                      : std::max(std::chrono::milliseconds(5000), 5 * period_ms);
            const std::shared_ptr<pb::Message> message = request_of(client, method, request, fields);
            auto stream = std::make_shared<RpcStream>();
            stream->owner = self;
            stream->method = name;
            stream->message_class = class_of(client.schema(), *method.output);
            stream->queue = std::make_shared<StreamQueue>();
            stream->remaining = count;
            stream->timeout = wait;
            rpc::StreamHandler handler = [queue = stream->queue](const rpc::error_code& error,
                                                                 const rpc::StreamMessage& m) {
              {
                const std::lock_guard lock(queue->mutex);
                if (error) {
                  queue->end = error;
                  queue->end_error = m.device_error;
                } else if (m.message) {
                  if (queue->messages.size() == StreamQueue::kCapacity) {
                    queue->messages.pop_front();
                    ++queue->dropped;
                  }
                  queue->messages.emplace_back(m.message->SerializeAsString(), m.seq);
                }
              }
              queue->changed.notify_all();
            };
            try {
              py::gil_scoped_release release;
              stream->stream = client.open_stream(name, *message, period_ms, std::move(handler));
            } catch (const boost::system::system_error& failure) {
              raise_failure(failure.code(), {}, name);
            }
            return stream;
          },
          py::arg("method"), py::arg("request") = py::none(), py::kw_only(), py::arg("period"),
          py::arg("count") = py::none(), py::arg("timeout") = py::none(),
          "Opens a stream of ``method`` every ``period`` seconds (0.001..65.535) and returns it (iterate it). "
          "``count``: stop after that many messages; ``timeout``: longest wait for a message (default 5 s or 5 "
          "periods). Request fields as for ``call`` (keyword arguments after ``period``).")
      .def("on_event", [](RpcClient& self, py::object callback) {
        if (!PyCallable_Check(callback.ptr())) throw py::type_error("expected a callable");
        return self.get().on_event(python_handler(std::move(callback)));
      }, py::arg("callback"), "Adds an event handler (``callback(event)`` on the io thread); returns its id.")
      .def("remove_event_handler", [](RpcClient& self, std::uint64_t id) { self.get().remove_event_handler(id); },
           py::arg("id"), "Removes an event handler.")
      .def("counters", [](RpcClient& self) { return self.get().counters(); }, "Snapshot of the counters.")
      .def(
          "session",
          [](RpcClient& self) {
            const rpc::SessionStatus status = self.get().session();
            return py::module_::import("types").attr("SimpleNamespace")(
                "established"_a = status.established, "session_id"_a = status.session_id,
                "device_hash"_a = status.device_hash);
          },
          "Where the session stands: ``established``, ``session_id`` and the ``device_hash`` last received "
          "(None before the first).")
      .def("close", [](RpcClient& self) {
        if (!self.client || self.generation.inherited()) return;  // inherited: nothing of it runs here
        py::gil_scoped_release release;
        self.client->close();
      }, "Closes the client: calls in flight raise ``ClosedError``, streams end. Idempotent.")
      .def_property_readonly("is_open", [](const RpcClient& self) {
        return self.client && !self.generation.inherited() && self.client->is_open();
      }, "False after ``close()``.")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](RpcClient& self, py::args) {
        if (!self.client || self.generation.inherited()) return;
        py::gil_scoped_release release;
        self.client->close();
      });
}

}  // namespace tether::python

namespace tether::rpc {

/// The codec's part of the Python module (collected by python/CMakeLists.txt: plugin_python.cpp.in).
void register_python(pybind11::module_& module);

void register_python(pybind11::module_& module) { python::register_rpc(module); }

}  // namespace tether::rpc
