// Host fake of the pin drivers (tether/proxy/device/hardware.hpp): records what each pin is driven to.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace fake {

/// What the fake "MCU" does with one pin.
struct Pin {
  bool servo = false;       ///< Timer1 drives it (attached).
  uint16_t pulse_us = 0;    ///< Last pulse width written (attached or not).
  bool output = false;      ///< A digital output (DDR bit set).
  bool level = false;       ///< PORT bit.
};

/// Every pin, and the calls in order ("attach 9 1500", "write 9 2000", "detach 9", "init 13 1", "set 13 0").
struct Hardware {
  Pin pins[20];
  std::vector<std::string> calls;
};

/// The fake's state; `reset()` clears it.
Hardware& hardware();
void reset();

}  // namespace fake
