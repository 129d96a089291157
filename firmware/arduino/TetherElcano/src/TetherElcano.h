/// @file TetherElcano.h
/// Tether's Elcano ring node for sketches that want it directly (tether::elcano::RingNode: feed bytes,
/// read events, originate, take paced output; docs/elcano.md) rather than through the ElcanoSerial API
/// (ElcanoSerial.h, which this includes too).
#pragma once

#include "ElcanoSerial.h"
#include "TetherSetArduinoMacrosAside.h"  // Arduino.h's bit, min, max, ... would rewrite Tether's names
#include "tether/elcano/message.hpp"
#include "tether/elcano/ring_node.hpp"
#include "TetherRestoreArduinoMacros.h"
