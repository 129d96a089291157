/// @file TetherSetArduinoMacrosAside.h
/// Include before Tether's headers in an Arduino library's glue, and `TetherRestoreArduinoMacros.h` after
/// them: Arduino.h defines function-like macros (bit, min, max, ...) that would rewrite Tether's members of
/// those names, so they are set aside (pushed and undefined) while Tether's headers are read. No include
/// guard on purpose: every glue header brackets its own includes. Part of TetherCore.
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
