/// @file TetherRestoreArduinoMacros.h
/// Brings back the Arduino macros `TetherSetArduinoMacrosAside.h` set aside, after Tether's headers (the
/// sketch keeps Arduino's bit, min, max, ...). No include guard on purpose: one per bracket.
#pragma pop_macro("constrain")
#pragma pop_macro("round")
#pragma pop_macro("abs")
#pragma pop_macro("max")
#pragma pop_macro("min")
#pragma pop_macro("bit")
