// The Python-side objects of the clients: each holds its client, the io thread running it and whatever
// owns the stream (a rover, a virtual board). Destroyed with the GIL released: closing a client drops its
// Python callbacks, which take the GIL themselves.
#pragma once

#include <memory>

#include "binding.hpp"
#include "tether/elcano/client.hpp"
#include "tether/proxy/client.hpp"
#include "tether/romi/client.hpp"

namespace tether::python {

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

/// `tether.proxy.Client`.
struct ProxyClient {
  std::shared_ptr<transports::IoThread> io;
  std::shared_ptr<proxy::Client> client;
  std::shared_ptr<void> owner;
  ProcessGeneration generation;
  ~ProxyClient();
  proxy::Client& get();
};

/// `tether.elcano.RingClient`.
struct RingClient {
  std::shared_ptr<transports::IoThread> io;
  std::shared_ptr<elcano::RingClient> client;
  std::shared_ptr<void> owner;
  ProcessGeneration generation;
  ~RingClient();
  elcano::RingClient& get();
};

/// A JSON value as Python (lists, dicts, ints, strings).
py::object json_to_python(const nlohmann::json& value);

}  // namespace tether::python
