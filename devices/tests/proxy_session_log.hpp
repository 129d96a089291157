// The sessions a proxy client establishes, as they come: for tests that wait for the client to start a new
// session by itself (after its port came back).
#pragma once

#include <mutex>
#include <variant>
#include <vector>

#include "tether/proxy/client.hpp"
#include "unpluggable_board.hpp"

namespace tether::devices::testing {

class ProxySessionLog {
 public:
  // Listens from now on; the client's events must end (the rover closed) before the log goes.
  explicit ProxySessionLog(proxy::Client& client) {
    client.on_event([this](const proxy::Event& event) {
      if (const auto* established = std::get_if<proxy::events::SessionEstablished>(&event)) {
        std::lock_guard lock(mutex_);
        sessions_.push_back(*established);
      }
    });
  }
  // Waits (bounded by wait_until's limit) for a first session; false if none came.
  bool wait_first() {
    return wait_until([this] {
      std::lock_guard lock(mutex_);
      return !sessions_.empty();
    });
  }
  std::vector<proxy::events::SessionEstablished> sessions() {
    std::lock_guard lock(mutex_);
    return sessions_;
  }

 private:
  std::mutex mutex_;
  std::vector<proxy::events::SessionEstablished> sessions_;
};

}  // namespace tether::devices::testing
