// tether.elcano: the host's node in an Elcano ring (elcano::RingClient) and its messages.
#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <type_traits>
#include <variant>

#include "binding.hpp"
#include "rover_holder.hpp"
#include "tether/elcano/client.hpp"
#include "tether/elcano/plugin.hpp"
#include "virtual_board.hpp"

namespace tether::python {

/// `tether.elcano.RingClient`.
struct RingClient : ClientHolder<elcano::RingClient> {
  elcano::RingClient& get() { return ClientHolder::get("the ring client"); }
};

namespace {

// The message fields by their Python names (None when kUnset).
struct Field {
  const char* name;
  std::int32_t elcano::Message::*member;
};
constexpr Field kFields[] = {
    {"number", &elcano::Message::number},     {"speed", &elcano::Message::speed},
    {"angle", &elcano::Message::angle},       {"obstacle", &elcano::Message::obstacle},
    {"bearing", &elcano::Message::bearing},   {"probability", &elcano::Message::probability},
    {"east", &elcano::Message::east},         {"north", &elcano::Message::north},
};

elcano::Type type_from(py::handle name) {
  if (!py::isinstance<py::str>(name)) {
    throw py::type_error("a message type is a str ('drive', 'sensor', 'goal', 'segment' or D, S, G, X)");
  }
  const auto text = name.cast<std::string>();
  elcano::Type type{};
  if (!elcano::type_from_name(ByteView(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()), type)) {
    throw py::value_error("unknown message type '" + text + "' (expected drive, sensor, goal, segment or D, S, G, X)");
  }
  return type;
}

std::int32_t field_value(py::handle value, const char* name) {
  if (!py::isinstance<py::int_>(value) || py::isinstance<py::bool_>(value)) {
    throw py::type_error(std::string(name) + " must be an int, got " +
                         py::str(py::type::of(value).attr("__name__")).cast<std::string>());
  }
  const auto number = value.cast<long long>();
  if (number < std::numeric_limits<std::int32_t>::min() || number >= elcano::kUnset) {
    throw py::value_error(std::string(name) + " " + std::to_string(number) + " is outside -2147483648..2147483646");
  }
  return static_cast<std::int32_t>(number);
}

std::string message_repr(const elcano::Message& message) {
  std::string text = std::string("Message(type='") + elcano::to_string(message.type) + "'";
  for (const Field& field : kFields) {
    if (message.*field.member != elcano::kUnset) text += std::string(", ") + field.name + "=" + std::to_string(message.*field.member);
  }
  return text + ")";
}

elcano::Generation generation_from(const std::string& name) {
  if (name == "B" || name == "b") return elcano::Generation::b;
  if (name == "D" || name == "d") return elcano::Generation::d;
  throw py::value_error("generation is 'B' or 'D', got '" + name + "'");
}

Duration milliseconds(double seconds, const char* name) {
  if (!(seconds >= 0.0) || seconds > 3600.0) throw py::value_error(std::string(name) + " must be 0..3600 s");
  return static_cast<Duration>(std::lround(seconds * 1000.0));
}

// The Python surface keeps one namespace per event: `kind` names it; `message`, `error` and
// `request_failed` are set where the kind has them (None, not a default message or "success").
py::object ring_event(const elcano::Event& ring_event) {
  const char* kind = "";
  py::object message = py::none();
  py::object error = py::none();
  bool request_failed = false;
  std::visit(
      [&](const auto& event) {
        using E = std::decay_t<decltype(event)>;
        if constexpr (std::is_same_v<E, elcano::events::Undeliverable>) {
          kind = "undeliverable";
          message = py::cast(event.message);
          request_failed = event.request_failed;
        } else if constexpr (std::is_same_v<E, elcano::events::InputDropped>) {
          kind = "read_error";
          error = py::str(std::string(elcano::describe(event.error)));
        } else if constexpr (std::is_same_v<E, elcano::events::ForwardDropped>) {
          kind = "forward_dropped";
          message = py::cast(event.message);
        } else if constexpr (std::is_same_v<E, elcano::events::ReceiveOverflow>) {
          kind = "receive_overflow";
          message = py::cast(event.message);
        } else {
          static_assert(std::is_same_v<E, elcano::events::LinkFailed>, "every Elcano event has a kind");
          kind = "link_failed";
          error = py::str(event.error.message());
        }
      },
      ring_event);
  return py::module_::import("types").attr("SimpleNamespace")("kind"_a = kind, "message"_a = message,
                                                              "error"_a = error, "request_failed"_a = request_failed);
}

// `start` begins the operation with its handler bound to the future's cancellation.
py::object message_future(
    const std::function<void(client::CancellationSignal, elcano::detail::MessageHandler)>& start) {
  return asyncio_future([&](PyCallback settle, client::CancellationSignal cancel) {
    start(std::move(cancel), [settle](elcano::error_code error, elcano::Message reply) {
      if (interpreter_exiting()) return;
      py::gil_scoped_acquire gil;
      if (error) {
        settle(error_object(error), py::none());
      } else {
        settle(py::none(), py::cast(reply));
      }
    });
  });
}

}  // namespace

void register_elcano(py::module_& parent);

void register_elcano(py::module_& parent) {
  rover_class(parent).def(
      "elcano",
      [](const std::shared_ptr<RoverHolder>& holder, const std::string& device) {
        return client_of<RingClient>(holder, device, [](devices::Rover& rover, const std::string& n) { return rover.client<elcano::RingClient>(n); });
      },
      py::arg("name"), "The ring client of the elcano device ``name``.");

  py::module_ module = parent.def_submodule("elcano", "The Elcano ring: the host as one node of a ring of boards.");
  register_errors(module, {"tether.elcano",
                           {"ElcanoError", "An Elcano ring operation failed (``code`` is the ``RingError`` value: "
                                           "1 timed_out, 2 undeliverable, 3 reply_type_busy, 4 send_queue_full, "
                                           "5 send_timed_out, 6 receive_timed_out, 7 invalid_message, "
                                           "8 invalid_reply_type)."},
                           {"ElcanoTimeoutError", "No reply, room or message in time."},
                           {"ElcanoMessageError", "The message or reply type was rejected before anything was written."},
                           {7, 8},
                           {}});

  py::class_<elcano::Message> message_class(module, "Message", R"doc(One Elcano message: ``Message(type='drive', speed=50, angle=25)``.

``type`` is drive, sensor, goal or segment (or D, S, G, X); fields not given are None and not written.
Required per type: drive speed angle; sensor speed angle east north bearing; goal number east north bearing;
segment number east north bearing speed.)doc");
  message_class
      .def(py::init([](py::handle type, const py::kwargs& fields) {
             elcano::Message made;
             made.type = type_from(type);
             for (const auto& [key, value] : fields) {
               const auto name = key.cast<std::string>();
               bool known = false;
               for (const Field& field : kFields) {
                 if (name == field.name) {
                   if (!value.is_none()) made.*field.member = field_value(value, field.name);
                   known = true;
                 }
               }
               if (!known) throw py::type_error("Message has no field '" + name + "'");
             }
             return made;
           }),
           py::arg("type") = "drive")
      .def_property_readonly("type", [](const elcano::Message& m) { return elcano::to_string(m.type); },
                             "drive, sensor, goal or segment.")
      .def("__repr__", &message_repr)
      .def("__eq__", [](const elcano::Message& a, const elcano::Message& b) { return a == b; })
      .def(
          "to_wire",
          [](const elcano::Message& m, const std::string& generation) {
            std::uint8_t buffer[elcano::kMaxMessageBytes];
            const auto written = elcano::encode_message(m, generation_from(generation), MutableByteView(buffer));
            if (!written.ok()) throw py::value_error("cannot write " + message_repr(m) + ": a required field is missing");
            return py::bytes(reinterpret_cast<const char*>(buffer), written.value());
          },
          py::arg("generation") = "B", "The message as it goes on the wire (``b'D{s 50}{a 25}\\n'``).");
  message_class.attr("__hash__") = py::none();
  for (const Field& field : kFields) {
    message_class.def_property_readonly(field.name, [member = field.member](const elcano::Message& m) -> py::object {
      if (m.*member == elcano::kUnset) return py::none();
      return py::int_(m.*member);
    });
  }

  py::class_<elcano::RingCounters>(module, "RingCounters", "What the host's node did in the ring.")
      .def_readonly("captured", &elcano::RingCounters::captured, "Messages consumed by the host.")
      .def_readonly("forwarded", &elcano::RingCounters::forwarded, "Messages passed on to the first board.")
      .def_readonly("originated", &elcano::RingCounters::originated, "Messages the host sent (re-sends included).")
      .def_readonly("undeliverable", &elcano::RingCounters::undeliverable, "Own messages that came back.")
      .def_readonly("queue_full_drops", &elcano::RingCounters::queue_full_drops, "Forwarding drops (queue full).")
      .def_readonly("origins_expired", &elcano::RingCounters::origins_expired, "Origin records expired.")
      .def_readonly("origins_evicted", &elcano::RingCounters::origins_evicted, "Origin records overwritten.");

  py::class_<elcano::Counters>(module, "Counters", "What a ring client counted (a snapshot; they only grow).")
      .def_readonly("link", &elcano::Counters::link, "Reader and engine (retries = request re-sends, timeouts).")
      .def_readonly("ring", &elcano::Counters::ring, "The node: captured, forwarded, originated, ...")
      .def_readonly("replies", &elcano::Counters::replies, "Captured messages that completed a request.")
      .def_readonly("receive_overflows", &elcano::Counters::receive_overflows, "Captured messages dropped (queue full).")
      .def_readonly("bytes_written", &elcano::Counters::bytes_written, "Bytes handed to the stream.");

  py::class_<RingClient, std::shared_ptr<RingClient>>(module, "RingClient", R"doc(The host's node in an Elcano ring (elcano::RingClient).

The stream's TX goes to the first board, its RX comes from the last. Messages of a captured type (``capture``,
plus a request's reply type while it waits) are consumed; every other message is forwarded. A request is
re-sent after each silent attempt (0.5 s) within its budget (2 s); one that comes back round the ring fails
at once (undeliverable). Events (undeliverable, read_error, forward_dropped, receive_overflow, link_failed)
go to ``on_event`` on the io thread, each a namespace of ``kind``, ``message`` (the message, for undeliverable,
forward_dropped and receive_overflow; else None), ``error`` (the text, for read_error and link_failed; else
None) and ``request_failed`` (undeliverable: a request failed with it). The GIL is released while waiting.
On a ``tether.VirtualUno`` (``Client(board)``) or with ``clock=board.clock``, every deadline runs on the
board's simulated time (see ``tether.romi.Client``).)doc")
      .def(py::init([](py::object port, const std::string& generation, std::vector<std::string> capture,
                       unsigned baud, double boot_wait, py::object on_event, py::object clock,
                       std::optional<std::string> boot, py::object record) {
             elcano::Options options;
             options.node.generation = generation_from(generation);
             for (const auto& name : capture) options.node.capture = options.node.capture.with(type_from(py::str(name)));
             options.node.pacing.baud = baud;
             std::shared_ptr<VirtualBoard> chosen = board_of_clock(clock);
             // Elcano boards announce nothing at boot and a ring has no request every board answers: `boot`
             // is "fixed" (the default) or "none"; "detect" is refused with the reason.
             Transport transport = take_stream(port, SerialArguments{baud, boot_wait, {}, true, 0, boot});
             elcano::DeviceOptions recorded;  // what the capture's interface says of the ring
             recorded.generation = options.node.generation;
             record_transport(transport, record, "elcano", recorded);
             const std::shared_ptr<VirtualBoard> board = deadline_board(std::move(chosen), transport);
             options.clock = link_clock(board);
             auto wrapper = std::make_shared<RingClient>();
             wrapper->io = transport.io;
             elcano::EventHandler handler;
             if (!on_event.is_none()) {
               handler = [callback = PyCallback(on_event)](const elcano::Event& event) {
                 if (interpreter_exiting()) return;
                 py::gil_scoped_acquire gil;
                 callback(ring_event(event));
               };
             }
             wrapper->client = std::make_shared<elcano::RingClient>(transport.stream, options, std::move(handler));
             wrapper->owner = join_board(board, wrapper->client, transport.keep_alive);
             return wrapper;
           }),
           py::arg("port_or_transport"), py::kw_only(), py::arg("generation") = "B",
           py::arg("capture") = std::vector<std::string>{}, py::arg("baud") = 115200u, py::arg("boot_wait") = 2.0,
           py::arg("on_event") = py::none(), py::arg("clock") = py::none(), py::arg("boot") = py::none(),
           py::arg("record") = py::none())
      .def(
          "request",
          [](RingClient& self, const elcano::Message& request, py::handle reply_type) {
            const elcano::Type reply = type_from(reply_type);
            elcano::RingClient& client = self.get();
            auto [error, answer] = wait_interruptibly<elcano::error_code, elcano::Message>(
                client.get_executor(), [&](client::CancellationSignal cancel, auto handler) {
                  client.async_request(request, reply, client::bind_cancellation(std::move(cancel), std::move(handler)));
                });
            if (error) raise_error(error);
            return answer;
          },
          py::arg("message"), py::kw_only(), py::arg("reply_type"),
          "Sends ``message`` and returns the first captured message of ``reply_type``. Raises "
          "ElcanoTimeoutError, ElcanoError (undeliverable, busy), ElcanoMessageError, ClosedError.")
      .def(
          "request_async",
          [](RingClient& self, const elcano::Message& request, py::handle reply_type) {
            const elcano::Type reply = type_from(reply_type);
            elcano::RingClient& client = self.get();
            return message_future([&](client::CancellationSignal cancel, elcano::detail::MessageHandler h) {
              client.async_request(request, reply, client::bind_cancellation(std::move(cancel), std::move(h)));
            });
          },
          py::arg("message"), py::kw_only(), py::arg("reply_type"), "``request`` for asyncio.")
      .def(
          "send",
          [](RingClient& self, const elcano::Message& message) {
            elcano::RingClient& client = self.get();
            auto [error] = wait_interruptibly<elcano::error_code>(client.get_executor(), [&](client::CancellationSignal cancel, auto handler) {
              client.async_send(message, client::bind_cancellation(std::move(cancel), std::move(handler)));
            });
            if (error) raise_error(error);
          },
          py::arg("message"), "Originates ``message``; returns once it was handed to the stream.")
      .def(
          "receive",
          [](RingClient& self, double timeout) {
            const Duration limit = milliseconds(timeout, "timeout");
            elcano::RingClient& client = self.get();
            auto [error, message] = wait_interruptibly<elcano::error_code, elcano::Message>(
                client.get_executor(), [&](client::CancellationSignal cancel, auto handler) {
                  client.async_receive(limit, client::bind_cancellation(std::move(cancel), std::move(handler)));
                });
            if (error) raise_error(error);
            return message;
          },
          py::arg("timeout") = 1.0, "The next captured message no request claimed, within ``timeout`` seconds.")
      .def("counters", [](RingClient& self) { return self.get().counters(); }, "Snapshot of the counters.")
      .def("close", [](RingClient& self) {
        if (!self.client || self.generation.inherited()) return;  // inherited: nothing of it runs here
        py::gil_scoped_release release;
        self.client->close();
      }, "Closes the node: pending operations raise ``ClosedError``. Idempotent.")
      .def_property_readonly("is_open", [](const RingClient& self) { return self.client && !self.generation.inherited() && self.client->is_open(); },
                             "False after ``close()``.")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](RingClient& self, py::args) {
        if (!self.client || self.generation.inherited()) return;  // inherited: nothing of it runs here
        py::gil_scoped_release release;
        self.client->close();
      });
}

}  // namespace tether::python

namespace tether::elcano {

/// The codec's part of the Python module (collected by python/CMakeLists.txt: plugin_python.cpp.in).
void register_python(pybind11::module_& module);

void register_python(pybind11::module_& module) { python::register_elcano(module); }

}  // namespace tether::elcano
