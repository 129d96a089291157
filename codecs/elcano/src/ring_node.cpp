#include "tether/elcano/ring_node.hpp"

namespace tether {
namespace elcano {

const char* to_string(RingEvent::Kind kind) {
  switch (kind) {
    case RingEvent::Kind::none: return "none";
    case RingEvent::Kind::captured: return "captured";
    case RingEvent::Kind::forwarded: return "forwarded";
    case RingEvent::Kind::undeliverable: return "undeliverable";
    case RingEvent::Kind::dropped: return "dropped";
  }
  return "unknown";
}

}  // namespace elcano
}  // namespace tether
