// tether.proxy: the proxy client (proxy::Client), primary and compat modes, events as namespaces.
#include <pybind11/stl.h>

#include <cmath>
#include <limits>

#include "binding.hpp"
#include "tether/proxy/plugin.hpp"
#include "rover_holder.hpp"
#include "tether/proxy/client.hpp"
#include "virtual_board.hpp"

namespace tether::python {

/// `tether.proxy.Client`.
struct ProxyClient : ClientHolder<proxy::Client> {
  proxy::Client& get() { return ClientHolder::get("the proxy client"); }
};

namespace {

const char* kind_name(proxy::PinKind kind) {
  switch (kind) {
    case proxy::PinKind::servo:
      return "servo";
    case proxy::PinKind::digital:
      return "digital";
    default:
      return "unknown";
  }
}

// Python ints checked into the client's types: TypeError for other types, ValueError out of range.
template <typename Int>
Int checked_int(py::handle value, const char* name) {
  if (!py::isinstance<py::int_>(value)) {
    throw py::type_error(std::string(name) + " must be an int, got " +
                         py::str(py::type::of(value).attr("__name__")).cast<std::string>());
  }
  const auto number = value.cast<long long>();
  if (number < static_cast<long long>(std::numeric_limits<Int>::min()) ||
      static_cast<unsigned long long>(number) > static_cast<unsigned long long>(std::numeric_limits<Int>::max()) ||
      (number < 0 && std::numeric_limits<Int>::min() == 0)) {
    throw py::value_error(std::string(name) + " " + std::to_string(number) + " is out of range (" +
                          std::to_string(std::numeric_limits<Int>::min()) + ".." +
                          std::to_string(std::numeric_limits<Int>::max()) + ")");
  }
  return static_cast<Int>(number);
}

bool checked_bool(py::handle value, const char* name) {
  if (py::isinstance<py::bool_>(value)) return value.cast<bool>();
  if (py::isinstance<py::int_>(value)) {
    const auto number = value.cast<long long>();
    if (number == 0 || number == 1) return number == 1;
    throw py::value_error(std::string(name) + " must be True/False (or 0/1), got " + std::to_string(number));
  }
  throw py::type_error(std::string(name) + " must be a bool, got " +
                       py::str(py::type::of(value).attr("__name__")).cast<std::string>());
}

py::object event_to_python(const proxy::Event& event) {
  py::object make = py::module_::import("types").attr("SimpleNamespace");
  return std::visit(
      [&](const auto& e) -> py::object {
        using E = std::decay_t<decltype(e)>;
        if constexpr (std::is_same_v<E, proxy::events::DeviceError>) {
          return make("kind"_a = "device_error", "text"_a = e.text,
                      "level"_a = e.level == proxy::ErrorLevel::fatal ? "fatal" : "warning");
        } else if constexpr (std::is_same_v<E, proxy::events::DeviceInfo>) {
          return make("kind"_a = "device_info", "session_id"_a = e.session_id,
                      "ping_failsafe_triggered"_a = e.ping_failsafe_triggered);
        } else if constexpr (std::is_same_v<E, proxy::events::FailsafeTriggered>) {
          return make("kind"_a = "failsafe_triggered", "session_id"_a = e.session_id);
        } else if constexpr (std::is_same_v<E, proxy::events::PinReport>) {
          return make("kind"_a = "pin_report", "pin_kind"_a = kind_name(e.kind), "pin"_a = e.pin, "value"_a = e.value,
                      "failsafe"_a = e.failsafe);
        } else if constexpr (std::is_same_v<E, proxy::events::PinLost>) {
          return make("kind"_a = "pin_lost", "pin_kind"_a = kind_name(e.kind), "pin"_a = e.pin,
                      "silent_ms"_a = e.silent_ms);
        } else if constexpr (std::is_same_v<E, proxy::events::SessionEstablished>) {
          return make("kind"_a = "session_established", "session_id"_a = e.session_id, "inits"_a = e.inits,
                      "first"_a = e.first);
        } else if constexpr (std::is_same_v<E, proxy::events::ResetDetected>) {
          return make("kind"_a = "reset_detected", "previous_session_id"_a = e.previous_session_id,
                      "reported_session_id"_a = e.reported_session_id);
        } else if constexpr (std::is_same_v<E, proxy::events::CompatEvent>) {
          return make("kind"_a = "compat_event", "type"_a = RocketryProto::EventTypes_Name(e.type), "data"_a = e.data);
        } else if constexpr (std::is_same_v<E, proxy::events::CompatError>) {
          return make("kind"_a = "compat_error", "type"_a = RocketryProto::ErrorTypes_Name(e.type), "data"_a = e.data);
        } else if constexpr (std::is_same_v<E, proxy::events::CompatState>) {
          return make("kind"_a = "compat_state", "text"_a = e.message.ShortDebugString());
        } else if constexpr (std::is_same_v<E, proxy::events::UndecodableMessage>) {
          return make("kind"_a = "undecodable", "payload"_a = py::bytes(e.payload), "malformed"_a = e.malformed);
        } else {
          return make("kind"_a = "link_failed", "error"_a = e.error.message());
        }
      },
      event);
}

// Starts the operation with its handler bound to the future's cancellation (client::bind_cancellation).
using AsyncSend = std::function<void(client::CancellationSignal, proxy::detail::SendHandler)>;

// The blocking form of a send: interruptible (Ctrl-C cancels the send and raises KeyboardInterrupt).
proxy::SendResult blocking(const proxy::Client& client, const AsyncSend& start) {
  auto [error, result] = wait_interruptibly<proxy::error_code, proxy::SendResult>(
      client.get_executor(), [&](client::CancellationSignal cancel, auto handler) { start(std::move(cancel), std::move(handler)); });
  if (error) raise_error(error);
  return result;
}

py::object asynchronous(const AsyncSend& start) {
  return asyncio_future([&](PyCallback settle, client::CancellationSignal cancel) {
    start(std::move(cancel), [settle](proxy::error_code error, proxy::SendResult result) {
      if (interpreter_exiting()) return;
      py::gil_scoped_acquire gil;
      if (error) {
        settle(error_object(error), py::none());
      } else {
        settle(py::none(), py::cast(result));
      }
    });
  });
}

// A pin's handle as Python holds it: the client wrapper (kept alive) and the pin.
struct PinHandle {
  std::shared_ptr<ProxyClient> owner;  // not used for lifetime of the C++ client: the handle keeps it
  std::uint32_t pin = 0;
};
struct ServoPin : PinHandle {};
struct DigitalPin : PinHandle {};

py::object pin_status(const std::optional<proxy::PinStatus>& status) {
  if (!status) return py::none();
  return py::module_::import("types").attr("SimpleNamespace")(
      "pin_kind"_a = kind_name(status->kind), "pin"_a = status->pin,
      "value"_a = status->has_value ? py::object(py::int_(status->value)) : py::object(py::none()),
      "failsafe"_a = status->failsafe, "stale"_a = status->stale);
}

}  // namespace

void register_proxy(py::module_& parent);

void register_proxy(py::module_& parent) {
  rover_class(parent).def(
      "proxy",
      [](const std::shared_ptr<RoverHolder>& holder, const std::string& device) {
        return client_of<ProxyClient>(holder, device, [](devices::Rover& rover, const std::string& n) { return rover.client<proxy::Client>(n); });
      },
      py::arg("name"), "The client of the proxy or proxy-compat device ``name``.");

  py::module_ module = parent.def_submodule(
      "proxy", "The COBS + CRC-16 protobuf protocol (primary) and the deployed variant (compat).");
  register_errors(module, {"tether.proxy",
                           {"ProxyError", "A proxy send failed (``code`` is the ``ProxyError`` value: 1 timed_out, "
                                          "2 queue_timeout, 3 device_reset, 4 wrong_mode, 5 invalid_message, "
                                          "6 reserved_message, 7 message_too_large, 8 too_many_inits)."},
                           {"ProxyTimeoutError", "No ack within the send budget, or not sent within the queue timeout."},
                           {"ProxyMessageError", "The message was rejected before anything was written."},
                           {4, 5, 6, 7, 8},
                           {}});

  py::class_<proxy::SendResult>(module, "SendResult", "What a send produced.")
      .def_readonly("message_id", &proxy::SendResult::message_id, "Primary: the messageId on the wire (0 in compat).")
      .def_readonly("attempts", &proxy::SendResult::attempts, "Frames sent (> 1 after re-sends).")
      .def_readonly("acked", &proxy::SendResult::acked, "Primary: the device acked it. Compat: False.")
      .def("__repr__", [](const proxy::SendResult& r) {
        return "SendResult(message_id=" + std::to_string(r.message_id) + ", attempts=" + std::to_string(r.attempts) +
               ", acked=" + (r.acked ? "True" : "False") + ")";
      });

  py::class_<proxy::Counters>(module, "Counters", "What a proxy client counted (a snapshot; they only grow).")
      .def_readonly("link", &proxy::Counters::link, "Decoder and engine (stale acks, retries, timeouts, resets).")
      .def_readonly("undecodable", &proxy::Counters::undecodable, "Intact frames that are not the mode's ArduinoOut.")
      .def_readonly("unknown_messages", &proxy::Counters::unknown_messages, "Valid protobuf with an unknown oneof.")
      .def_readonly("messages_sent", &proxy::Counters::messages_sent, "Application messages and replays sent.")
      .def_readonly("acks", &proxy::Counters::acks, "Acks that completed a message.")
      .def_readonly("pings_sent", &proxy::Counters::pings_sent, "Heartbeat pings written.")
      .def_readonly("ping_acks", &proxy::Counters::ping_acks, "Acks of pings.")
      .def_readonly("resets_sent", &proxy::Counters::resets_sent, "Reset messages written.")
      .def_readonly("inits_replayed", &proxy::Counters::inits_replayed, "Inits re-sent after a device reset.")
      .def_readonly("pins_lost", &proxy::Counters::pins_lost, "Compat: PinLost events.");

  py::class_<ServoPin>(module, "Servo", "A servo output of one client: ``client.servo(9)``.")
      .def_property_readonly("pin", [](const ServoPin& s) { return s.pin; }, "The pin.")
      .def(
          "init",
          [](const ServoPin& s, py::handle safe_position) {
            const auto value = checked_int<std::int32_t>(safe_position, "safe_position");
            auto handle = s.owner->get().servo(s.pin);
            return blocking(s.owner->get(), [&](client::CancellationSignal cancel, proxy::detail::SendHandler h) {
              handle.async_init(value, client::bind_cancellation(std::move(cancel), std::move(h)));
            });
          },
          py::arg("safe_position"),
          "Registers ServoInit{pin, safe_position} for replay after device resets and sends it; blocks until "
          "acked (compat: written). Raises ProxyError / ProxyTimeoutError / ClosedError.")
      .def(
          "set",
          [](const ServoPin& s, py::handle position) {
            const auto value = checked_int<std::int32_t>(position, "position");
            auto handle = s.owner->get().servo(s.pin);
            return blocking(s.owner->get(), [&](client::CancellationSignal cancel, proxy::detail::SendHandler h) {
              handle.async_set(value, client::bind_cancellation(std::move(cancel), std::move(h)));
            });
          },
          py::arg("position"), "Sends ServoControl{pin, position}; blocks until acked (compat: written).")
      .def(
          "init_async",
          [](const ServoPin& s, py::handle safe_position) {
            const auto value = checked_int<std::int32_t>(safe_position, "safe_position");
            auto handle = s.owner->get().servo(s.pin);
            return asynchronous([&](client::CancellationSignal cancel, proxy::detail::SendHandler h) {
              handle.async_init(value, client::bind_cancellation(std::move(cancel), std::move(h)));
            });
          },
          py::arg("safe_position"), "``init`` for asyncio (a future of the running loop).")
      .def(
          "set_async",
          [](const ServoPin& s, py::handle position) {
            const auto value = checked_int<std::int32_t>(position, "position");
            auto handle = s.owner->get().servo(s.pin);
            return asynchronous([&](client::CancellationSignal cancel, proxy::detail::SendHandler h) {
              handle.async_set(value, client::bind_cancellation(std::move(cancel), std::move(h)));
            });
          },
          py::arg("position"), "``set`` for asyncio (a future of the running loop).")
      .def("state", [](const ServoPin& s) { return pin_status(s.owner->get().servo(s.pin).state()); },
           "The pin's last known state (pin_kind, pin, value or None, failsafe, stale), or None.");

  py::class_<DigitalPin>(module, "Digital", "A digital output of one client: ``client.digital(13)``.")
      .def_property_readonly("pin", [](const DigitalPin& d) { return d.pin; }, "The pin.")
      .def(
          "init",
          [](const DigitalPin& d, py::handle safe_state) {
            const bool value = checked_bool(safe_state, "safe_state");
            auto handle = d.owner->get().digital(d.pin);
            return blocking(d.owner->get(), [&](client::CancellationSignal cancel, proxy::detail::SendHandler h) {
              handle.async_init(value, client::bind_cancellation(std::move(cancel), std::move(h)));
            });
          },
          py::arg("safe_state"), "Registers DigitalInit{pin, safe_state} for replay and sends it; blocks.")
      .def(
          "set",
          [](const DigitalPin& d, py::handle state) {
            const bool value = checked_bool(state, "state");
            auto handle = d.owner->get().digital(d.pin);
            return blocking(d.owner->get(), [&](client::CancellationSignal cancel, proxy::detail::SendHandler h) {
              handle.async_set(value, client::bind_cancellation(std::move(cancel), std::move(h)));
            });
          },
          py::arg("state"), "Sends DigitalControl{pin, state}; blocks until acked (compat: written).")
      .def(
          "set_async",
          [](const DigitalPin& d, py::handle state) {
            const bool value = checked_bool(state, "state");
            auto handle = d.owner->get().digital(d.pin);
            return asynchronous([&](client::CancellationSignal cancel, proxy::detail::SendHandler h) {
              handle.async_set(value, client::bind_cancellation(std::move(cancel), std::move(h)));
            });
          },
          py::arg("state"), "``set`` for asyncio (a future of the running loop).")
      .def("state", [](const DigitalPin& d) { return pin_status(d.owner->get().digital(d.pin).state()); },
           "The pin's last known state, or None.");

  py::class_<ProxyClient, std::shared_ptr<ProxyClient>>(module, "Client", R"doc(Proxy client for one device (proxy::Client).

Primary mode: the client resets the device, waits for its session, pings every second, acks and re-sends
every message, and after a device reset replays every init without the application. ``compat=True`` speaks
the deployed variant (57600 baud, no CRC, no acks: a send completes when written). Events (acks are the
sends' completions; device errors, pin reports, session changes, ...) go to ``on_event(event)`` on the io
thread, as ``types.SimpleNamespace`` objects with a ``kind``. The GIL is released while waiting.
On a ``tether.VirtualUno`` (``Client(board)``) or with ``clock=board.clock``, every deadline runs on the
board's simulated time (see ``tether.romi.Client``).)doc")
      .def(py::init([](py::object port, bool compat, std::optional<unsigned> baud, double boot_wait,
                       double send_budget, std::optional<std::uint32_t> first_message_id, py::object on_event,
                       py::object clock, std::optional<std::string> boot, py::object record) {
             if (!(send_budget > 0.0) || send_budget > 3600.0) throw py::value_error("send_budget must be 0 < t <= 3600 s");
             proxy::Options options = compat ? proxy::Options::compat() : proxy::Options::primary();
             if (baud) options.timing.baud = *baud;
             options.timing.send_budget = static_cast<Duration>(std::lround(send_budget * 1000.0));
             options.first_message_id = first_message_id;
             std::shared_ptr<VirtualBoard> chosen = board_of_clock(clock);
             Transport transport = take_stream(port, SerialArguments{options.timing.baud, boot_wait, {}, true, 0, boot, compat ? transports::BootSignature{} : proxy::boot_signature()});
             record_transport(transport, record, compat ? "proxy-compat" : "proxy");
             const std::shared_ptr<VirtualBoard> board = deadline_board(std::move(chosen), transport);
             options.clock = link_clock(board);
             auto wrapper = std::make_shared<ProxyClient>();
             wrapper->io = transport.io;
             proxy::EventHandler handler;
             if (!on_event.is_none()) {
               handler = [callback = PyCallback(on_event)](const proxy::Event& event) {
                 if (interpreter_exiting()) return;
                 py::gil_scoped_acquire gil;
                 callback(event_to_python(event));
               };
             }
             wrapper->client = std::make_shared<proxy::Client>(transport.stream, options, std::move(handler));
             wrapper->owner = join_board(board, wrapper->client, transport.keep_alive);
             return wrapper;
           }),
           py::arg("port_or_transport"), py::kw_only(), py::arg("compat") = false, py::arg("baud") = py::none(),
           py::arg("boot_wait") = 2.0, py::arg("send_budget") = 1.0, py::arg("first_message_id") = py::none(),
           py::arg("on_event") = py::none(), py::arg("clock") = py::none(), py::arg("boot") = py::none(), py::arg("record") = py::none())
      .def(
          "servo",
          [](const std::shared_ptr<ProxyClient>& self, py::handle pin) {
            return ServoPin{{self, checked_int<std::uint32_t>(pin, "pin")}};
          },
          py::arg("pin"), "The servo on ``pin``.")
      .def(
          "digital",
          [](const std::shared_ptr<ProxyClient>& self, py::handle pin) {
            return DigitalPin{{self, checked_int<std::uint32_t>(pin, "pin")}};
          },
          py::arg("pin"), "The digital output on ``pin``.")
      .def(
          "on_event",
          [](ProxyClient& self, py::object callback) {
            if (!PyCallable_Check(callback.ptr())) throw py::type_error("expected a callable");
            return self.get().on_event([handler = PyCallback(callback)](const proxy::Event& event) {
              if (interpreter_exiting()) return;
              py::gil_scoped_acquire gil;
              handler(event_to_python(event));
            });
          },
          py::arg("callback"), "Adds an event handler (``callback(event)`` on the io thread); returns its id.")
      .def("remove_event_handler", [](ProxyClient& self, std::uint64_t id) { self.get().remove_event_handler(id); },
           py::arg("id"), "Removes an event handler.")
      .def("reset_failsafe",
           [](ProxyClient& self) {
             proxy::Client& client = self.get();
             return blocking(client, [&](client::CancellationSignal cancel, proxy::detail::SendHandler h) {
               client.async_reset_failsafe(client::bind_cancellation(std::move(cancel), std::move(h)));
             });
           },
           "Primary: sends PingFailsafeReset (clears the device's failsafe flag); blocks until acked.")
      .def("restart_session", [](ProxyClient& self) { self.get().restart_session(); },
           "Resets the device and re-runs the handshake (inits replayed). Returns at once.")
      .def("counters", [](ProxyClient& self) { return self.get().counters(); }, "Snapshot of the counters.")
      .def(
          "session",
          [](ProxyClient& self) {
            const proxy::SessionStatus status = self.get().session();
            return py::module_::import("types").attr("SimpleNamespace")("established"_a = status.established,
                                                                        "session_id"_a = status.session_id);
          },
          "Where the session stands: ``established`` and ``session_id`` (primary; None before the first).")
      .def(
          "pin_states",
          [](ProxyClient& self) {
            py::list states;
            for (const auto& status : self.get().pin_states()) states.append(pin_status(status));
            return states;
          },
          "Every known pin's last state, ordered by (kind, pin).")
      .def_property_readonly("compat", [](ProxyClient& self) { return self.get().mode() == proxy::Mode::compat; },
                             "True in compatibility mode.")
      .def("close", [](ProxyClient& self) {
        if (!self.client || self.generation.inherited()) return;  // inherited: nothing of it runs here
        py::gil_scoped_release release;
        self.client->close();
      }, "Closes the client: pending sends raise ``ClosedError``. Idempotent.")
      .def_property_readonly("is_open", [](const ProxyClient& self) { return self.client && !self.generation.inherited() && self.client->is_open(); },
                             "False after ``close()``.")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](ProxyClient& self, py::args) {
        if (!self.client || self.generation.inherited()) return;  // inherited: nothing of it runs here
        py::gil_scoped_release release;
        self.client->close();
      });
}

}  // namespace tether::python

namespace tether::proxy {

/// The codec's part of the Python module (collected by python/CMakeLists.txt: plugin_python.cpp.in).
void register_python(pybind11::module_& module);

void register_python(pybind11::module_& module) { python::register_proxy(module); }

}  // namespace tether::proxy
