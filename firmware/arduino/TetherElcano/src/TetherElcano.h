/// @file TetherElcano.h
/// Tether's Elcano ring node for sketches that want it directly (tether::elcano::RingNode: feed bytes,
/// read events, originate, take paced output; docs/elcano.md) rather than through the ElcanoSerial API
/// (ElcanoSerial.h, which this includes too).
#pragma once

#include "ElcanoSerial.h"
// Arduino.h defines function-like macros (bit, min, max, ...) that would rewrite Tether's members of those
// names: they are set aside while Tether's headers are read.
#pragma push_macro("bit")
#pragma push_macro("min")
#pragma push_macro("max")
#pragma push_macro("abs")
#pragma push_macro("round")
#pragma push_macro("constrain")
#undef bit
#undef min
#undef max
#undef abs
#undef round
#undef constrain
#include "tether/elcano/message.hpp"
#include "tether/elcano/ring_node.hpp"
#pragma pop_macro("constrain")
#pragma pop_macro("round")
#pragma pop_macro("abs")
#pragma pop_macro("max")
#pragma pop_macro("min")
#pragma pop_macro("bit")
