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
  bool pull_up = false;     ///< Compat: an input with its pull-up.
  bool input_level = false; ///< Compat: what `input_read` returns (set by the test).
  int analog = -1;          ///< Compat: last analog_write value (-1: never).
};

/// Every pin, and the calls in order ("attach 9 1500", "write 9 2000", "detach 9", "init 13 1", "set 13 0";
/// compat: "servo 3 1500" (any-pin attach), "input 4 1" (pull-up), "analog 5 200").
struct Hardware {
  Pin pins[20];
  std::vector<std::string> calls;
  int servo_channels_free = 12;   ///< Compat: any_pin_servo_attach fails when 0.
  uint16_t adc[6] = {};           ///< Compat: what analog_read(channel) returns (set by the test).
  bool load_cell_ready = true;    ///< Compat: load_cell_read succeeds.
  uint32_t load_cell_value = 0;   ///< Compat: its value.
  int load_cell_begun = 0;        ///< Compat: load_cell_begin calls.
};

/// The fake's state; `reset()` clears it.
Hardware& hardware();
void reset();

}  // namespace fake
