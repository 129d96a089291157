// tether.romi: the Romi client (romi::Client) with answers as Python lists.
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <limits>
#include <mutex>
#include <vector>

#include "binding.hpp"
#include "tether/romi/plugin.hpp"
#include "rover_holder.hpp"
#include "tether/romi/client.hpp"
#include "virtual_board.hpp"
#include "tether/romi/client.hpp"

namespace tether::python {

// The Python-side object of the client: it holds the client, the io thread running it and whatever owns
// the stream (a rover, a virtual board). Destroyed with the GIL released: closing a client drops its Python
// callbacks, which take the GIL themselves.
/// Where a Romi client's log lines go: the `on_log` callback and every `log_lines()` iterator (romi.cpp).
struct RomiLogFanout;

/// `tether.romi.Client`.
struct RomiClient {
  std::shared_ptr<transports::IoThread> io;
  std::shared_ptr<romi::Client> client;
  std::shared_ptr<void> owner;
  std::shared_ptr<RomiLogFanout> logs;  // made (and set as the client's log handler) on first use
  ProcessGeneration generation;
  ~RomiClient();
  /// The client; raises ClosedError after close().
  romi::Client& get();
  /// The fan-out of log lines, installed as the client's log handler when first asked for.
  RomiLogFanout& log_fanout();
};

py::object json_to_python(const nlohmann::json& value) {
  switch (value.type()) {
    case nlohmann::json::value_t::null:
      return py::none();
    case nlohmann::json::value_t::boolean:
      return py::bool_(value.get<bool>());
    case nlohmann::json::value_t::number_integer:
      return py::int_(value.get<std::int64_t>());
    case nlohmann::json::value_t::number_unsigned:
      return py::int_(value.get<std::uint64_t>());
    case nlohmann::json::value_t::number_float:
      return py::float_(value.get<double>());
    case nlohmann::json::value_t::string:
      return py::str(value.get_ref<const std::string&>());
    case nlohmann::json::value_t::array: {
      py::list list;
      for (const auto& item : value) list.append(json_to_python(item));
      return list;
    }
    case nlohmann::json::value_t::object: {
      py::dict dict;
      for (const auto& [key, item] : value.items()) dict[py::str(key)] = json_to_python(item);
      return dict;
    }
    default:
      return py::none();
  }
}

namespace {

// `call('L[1]')` or `call('M', 16, 'Shutdown')`: the command the client validates.
romi::Command make_command(const std::string& command, const py::args& args) {
  if (args.empty()) return romi::Command(command);
  if (command.size() != 1) {
    throw py::value_error("with arguments, the command is one opcode character (call('M', 16, 'Shutdown')), got '" +
                          command + "'");
  }
  std::vector<std::int32_t> ints;
  std::optional<std::string> text;
  for (const auto& arg : args) {
    if (text) throw py::value_error("the string argument must be the last one");
    if (py::isinstance<py::str>(arg)) {
      text = arg.cast<std::string>();
    } else if (py::isinstance<py::int_>(arg)) {
      // Every int outside int16 is the one mistake, whatever its size: the client's own -10, raised here for
      // those no C++ integer holds (the client checks the rest, as it does for C++ callers).
      int overflow = 0;
      const long long value = PyLong_AsLongLongAndOverflow(arg.ptr(), &overflow);
      if (overflow != 0 || value < std::numeric_limits<std::int32_t>::min() ||
          value > std::numeric_limits<std::int32_t>::max()) {
        raise_error(romi::make_error_code(romi::Error::value_out_of_range),
                    "argument " + py::str(arg).cast<std::string>() + " is outside int16 (-32768..32767)");
      }
      ints.push_back(static_cast<std::int32_t>(value));
    } else {
      throw py::type_error("Romi arguments are int or str, got " +
                           py::str(py::type::of(arg).attr("__name__")).cast<std::string>());
    }
  }
  return romi::Command(command[0], ints, text ? std::optional<std::string_view>(*text) : std::nullopt);
}

// The answer as a list, or the exception for it (with the GIL).
py::object answer_or_error(const romi::error_code& error, const romi::RomiResponse& response, bool check,
                           py::object& failure) {
  if (error) {
    failure = error_object(error, response.message);
    return py::none();
  }
  py::object values = json_to_python(response.values);
  if (check && response.code != 0) {
    failure = py::module_::import("tether.romi").attr("RomiError")(response.code, response.message, values);
    return py::none();
  }
  return values;
}

session::CallTiming timing_from(double attempt_timeout, double call_budget, int max_attempts, bool retry_on_timeout) {
  if (!(attempt_timeout > 0.0) || !(call_budget > 0.0) || attempt_timeout > 3600.0 || call_budget > 3600.0) {
    throw py::value_error("attempt_timeout and call_budget must be 0 < t <= 3600 s");
  }
  if (max_attempts < 1 || max_attempts > 255) throw py::value_error("max_attempts must be 1..255");
  session::CallTiming timing = romi::default_call_timing();
  timing.attempt_timeout = static_cast<Duration>(std::lround(attempt_timeout * 1000.0));
  timing.call_budget = static_cast<Duration>(std::lround(call_budget * 1000.0));
  timing.max_attempts = static_cast<std::uint8_t>(max_attempts);
  timing.retry_on_timeout = retry_on_timeout;
  return timing;
}

}  // namespace

/// The lines one `log_lines()` iterator has not taken yet (bounded: the oldest go first when full).
struct RomiLogQueue {
  static constexpr std::size_t capacity = 1024;
  std::mutex mutex;
  std::condition_variable arrived;
  std::deque<std::string> lines;
  std::uint64_t dropped = 0;
  bool closed = false;  // the iterator's close(): no more lines
};

struct RomiLogFanout {
  std::mutex mutex;
  PyCallback callback;
  std::vector<std::weak_ptr<RomiLogQueue>> queues;

  // On the client's strand, one line at a time.
  void deliver(std::string_view line) {
    PyCallback to_call;
    std::vector<std::shared_ptr<RomiLogQueue>> live;
    {
      std::lock_guard lock(mutex);
      to_call = callback;
      std::erase_if(queues, [](const auto& queue) { return queue.expired(); });
      for (const auto& queue : queues) {
        if (auto held = queue.lock()) live.push_back(std::move(held));
      }
    }
    for (const auto& queue : live) {
      {
        std::lock_guard lock(queue->mutex);
        if (queue->closed) continue;
        if (queue->lines.size() == RomiLogQueue::capacity) {
          queue->lines.pop_front();
          ++queue->dropped;
        }
        queue->lines.emplace_back(line);
      }
      queue->arrived.notify_one();
    }
    to_call(std::string(line));
  }
};

namespace {

/// `tether.romi.LogLines`: iterates over a client's log lines from its creation on.
struct RomiLogLines {
  std::weak_ptr<romi::Client> client;  // to see it close (close(), the rover's, a failed link, destruction)
  std::shared_ptr<RomiLogQueue> queue;
  std::optional<std::chrono::milliseconds> timeout;

  std::string next() {
    const auto start = std::chrono::steady_clock::now();
    for (;;) {
      {
        py::gil_scoped_release release;
        std::unique_lock lock(queue->mutex);
        // Short slices: a closed client and Ctrl-C are noticed within 100 ms.
        queue->arrived.wait_for(lock, std::chrono::milliseconds(100), [this] { return !queue->lines.empty(); });
        if (queue->closed) throw py::stop_iteration();
        if (!queue->lines.empty()) {
          std::string line = std::move(queue->lines.front());
          queue->lines.pop_front();
          return line;
        }
      }
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      const auto held = client.lock();
      if (!held || !held->is_open() || (timeout && std::chrono::steady_clock::now() - start >= *timeout)) {
        throw py::stop_iteration();
      }
    }
  }
};

}  // namespace

RomiLogFanout& RomiClient::log_fanout() {
  romi::Client& romi_client = get();
  if (!logs) {
    logs = std::make_shared<RomiLogFanout>();
    romi_client.on_event([fanout = logs](const romi::Event& event) {
      if (const auto* line = std::get_if<romi::events::Log>(&event)) fanout->deliver(line->text);
    });
  }
  return *logs;
}

RomiClient::~RomiClient() {
  if (generation.inherited()) {  // the parent's threads run it: keep it as it is
    leak(client);
    leak(owner);
    leak(io);
    leak(logs);
    return;
  }
  py::gil_scoped_release release;
  client.reset();
  owner.reset();
  io.reset();
}

romi::Client& RomiClient::get() {
  if (generation.inherited()) raise_inherited("the Romi client");
  if (!client || !client->is_open()) raise_closed("the Romi client");
  return *client;
}

void register_romi(py::module_& parent);

void register_romi(py::module_& parent) {
  rover_class(parent).def(
      "romi",
      [](const std::shared_ptr<RoverHolder>& holder, const std::string& device) {
        return client_of<RomiClient>(holder, device, [](devices::Rover& rover, const std::string& n) { return rover.client<romi::Client>(n); });
      },
      py::arg("name"), "The client of the romi device ``name``.");

  py::module_ module = parent.def_submodule("romi", "The Romi text protocol: request/response with a Tether client.");
  register_errors(module, {"tether.romi",
                           {"RomiError", "A Romi call failed: the device's error code (-16 unknown opcode, > 0 application "
                                         "errors) or the client's (-25 timeout, -1..-6 damaged answers, "
                                         "-24/-14/-8..-13/-22/-32 rejected commands)."},
                           {"RomiTimeoutError", "No answer within the attempt window or the call budget (code -25)."},
                           {"RomiCommandError", "The command was rejected before anything was written (bad opcode, "
                                                "value out of int16, ...)."},
                           {-24, -14, -8, -9, -10, -11, -12, -13, -22, -32},
                           {}});

  py::class_<romi::Counters>(module, "Counters", "What a Romi client counted: the link's decoder and engine.")
      .def_readonly("link", &romi::Counters::link, "Decoder and engine counters.");

  py::class_<RomiLogLines>(module, "LogLines", "Iterator over a Romi client's log lines (``Client.log_lines``).")
      .def("__iter__", [](py::object self) { return self; })
      .def("__next__", &RomiLogLines::next)
      .def_property_readonly("dropped", [](const RomiLogLines& self) {
        std::lock_guard lock(self.queue->mutex);
        return self.queue->dropped;
      }, "Lines dropped because 1024 were waiting.")
      .def("close", [](RomiLogLines& self) {
        std::lock_guard lock(self.queue->mutex);
        self.queue->closed = true;
        self.queue->lines.clear();
      },
           "Stops collecting lines; iteration ends.");

  py::class_<RomiClient, std::shared_ptr<RomiClient>>(module, "Client", R"doc(Romi client for one device (romi::Client).

One call is in flight per device; calls from several threads queue in order. Each attempt waits
``attempt_timeout`` (1 s) for the answer; a call never takes more than ``call_budget`` (2 s) once sent.
A damaged answer or an envelope error (-1..-6) re-sends the same bytes (at most ``max_attempts``); a silent
attempt is re-sent only with ``retry_on_timeout`` (Tether firmware answers a repeat from its cache; the
reference firmware answers -15). Log lines (``#!text``) go to ``on_log``. The GIL is released while waiting.

``port_or_transport``: a serial port path (opened with ``baud`` and ``boot_wait`` seconds: an Uno resets when
its port opens), a ``tether.transports.Transport``, or a ``tether.VirtualUno``: its UART, and its simulated
time as the clock of every deadline. ``clock=board.clock`` puts a client opened otherwise on a board's time
(None: the board it was opened on, or whose pty it opened by path in this process, else the steady clock). On a
board's clock the windows are the device's seconds, exact whatever the machine's load; the board's ``close()`` closes the client.)doc")
      .def(py::init([](py::object port, unsigned baud, double boot_wait, double attempt_timeout, double call_budget,
                       int max_attempts, bool retry_on_timeout, py::object on_log, py::object clock, std::optional<std::string> boot, py::object record) {
             const session::CallTiming timing = timing_from(attempt_timeout, call_budget, max_attempts, retry_on_timeout);
             std::shared_ptr<VirtualBoard> chosen = board_of_clock(clock);
             Transport transport = take_stream(port, SerialArguments{baud, boot_wait, {}, true, 0, boot, romi::boot_signature()});
             record_transport(transport, record, "romi");
             const std::shared_ptr<VirtualBoard> board = deadline_board(std::move(chosen), transport);
             auto wrapper = std::make_shared<RomiClient>();
             wrapper->io = transport.io;
             romi::Options options;
             options.timing = timing;
             options.last_id = static_cast<std::uint8_t>(romi::random_first_id() - 1u);
             options.clock = link_clock(board);
             wrapper->client = std::make_shared<romi::Client>(transport.stream, options);
             wrapper->owner = join_board(board, wrapper->client, transport.keep_alive);
             if (!on_log.is_none()) {
               RomiLogFanout& fanout = wrapper->log_fanout();
               std::lock_guard lock(fanout.mutex);
               fanout.callback = PyCallback(on_log);
             }
             return wrapper;
           }),
           py::arg("port_or_transport"), py::kw_only(), py::arg("baud") = 115200u, py::arg("boot_wait") = 2.0,
           py::arg("attempt_timeout") = 1.0, py::arg("call_budget") = 2.0, py::arg("max_attempts") = 3,
           py::arg("retry_on_timeout") = false, py::arg("on_log") = py::none(), py::arg("clock") = py::none(), py::arg("boot") = py::none(), py::arg("record") = py::none())
      .def(
          "call",
          [](RomiClient& self, const std::string& command, const py::args& args, bool check) {
            romi::Command built = make_command(command, args);
            romi::Client& client = self.get();
            auto [error, response] = wait_interruptibly<romi::error_code, romi::RomiResponse>(
                client.get_executor(), [&](client::CancellationSignal cancel, auto handler) {
                  client.async_call(std::move(built), client::bind_cancellation(std::move(cancel), std::move(handler)));
                });
            py::object failure;
            py::object values = answer_or_error(error, response, check, failure);
            if (failure) {
              PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(failure.ptr())), failure.ptr());
              throw py::error_already_set();
            }
            return values;
          },
          py::arg("command"), py::kw_only(), py::arg("check") = true,
          R"doc(Sends a command and returns the device's answer as a list, code first: ``call('e')`` ->
``[0, 1, 2]``. ``call('L[1]')`` is raw text; ``call('M', 16, 'Shutdown')`` builds ``M[16,"Shutdown"]``
(ints in int16, then at most one string). Raises ``RomiError`` when the answer's code is not 0 (unless
``check=False``), ``RomiTimeoutError`` (also ``TimeoutError``) without an answer, ``RomiCommandError``
(also ``ValueError``) for a command rejected before sending, ``ClosedError`` after ``close()``.)doc")
      .def(
          "call_async",
          [](RomiClient& self, const std::string& command, const py::args& args, bool check) {
            romi::Command built = make_command(command, args);
            romi::Client& client = self.get();
            return asyncio_future([&](PyCallback settle, client::CancellationSignal cancel) {
              client.async_call(std::move(built), client::bind_cancellation(
                  std::move(cancel), [settle, check](romi::error_code error, romi::RomiResponse response) {
                    if (interpreter_exiting()) return;
                    py::gil_scoped_acquire gil;
                    py::object failure;
                    py::object values = answer_or_error(error, response, check, failure);
                    settle(failure ? failure : py::none(), values);
                  }));
            });
          },
          py::arg("command"), py::kw_only(), py::arg("check") = true,
          "``call`` for asyncio: returns a future of the running loop, completed from the io thread. Cancelling it\n"
          "(``task.cancel()``) cancels the call: queued, it is never sent; in flight, the client stops waiting\n"
          "for its answer and goes on with the next call.")
      .def(
          "on_log",
          [](RomiClient& self, py::object callback) {
            PyCallback handler(callback);
            RomiLogFanout& fanout = self.log_fanout();
            std::lock_guard lock(fanout.mutex);
            fanout.callback = std::move(handler);
          },
          py::arg("callback"),
          "Sets the log-line callback (``callback(text)``, on the io thread; None: no callback).")
      .def(
          "log_lines",
          [](RomiClient& self, std::optional<double> timeout) {
            if (timeout && (!(*timeout >= 0.0) || *timeout > 86400.0)) {
              throw py::value_error("timeout must be None or 0..86400 s");
            }
            RomiLogFanout& fanout = self.log_fanout();
            RomiLogLines lines;
            lines.client = self.client;
            lines.queue = std::make_shared<RomiLogQueue>();
            if (timeout) lines.timeout = std::chrono::milliseconds(std::lround(*timeout * 1000.0));
            std::lock_guard lock(fanout.mutex);
            fanout.queues.push_back(lines.queue);
            return lines;
          },
          py::kw_only(), py::arg("timeout") = py::none(),
          R"doc(An iterator over the log lines (``#!text``) that arrive from now on: ``for line in
client.log_lines(timeout=1.0): ...``. ``next()`` waits for the next line (the GIL released); iteration
ends when the client is closed (or its link fails) and the lines received are taken, or when no line came
within ``timeout`` seconds (None: wait while the client is open). At most 1024 lines wait: beyond that
the oldest are dropped and counted in ``dropped``. Works alongside ``on_log``.)doc")
      .def("counters", [](RomiClient& self) { return self.get().counters(); }, "Snapshot of the link counters.")
      .def("close", [](RomiClient& self) {
        if (!self.client || self.generation.inherited()) return;  // inherited: nothing of it runs here
        py::gil_scoped_release release;
        self.client->close();
      }, "Closes the client: calls in flight and queued raise ``ClosedError``. Idempotent.")
      .def_property_readonly("is_open", [](const RomiClient& self) { return self.client && !self.generation.inherited() && self.client->is_open(); },
                             "False after ``close()``.")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](RomiClient& self, py::args) {
        if (!self.client || self.generation.inherited()) return;  // inherited: nothing of it runs here
        py::gil_scoped_release release;
        self.client->close();
      });
}

}  // namespace tether::python

namespace tether::romi {

/// The codec's part of the Python module (collected by python/CMakeLists.txt: plugin_python.cpp.in).
void register_python(pybind11::module_& module);

void register_python(pybind11::module_& module) { python::register_romi(module); }

}  // namespace tether::romi
