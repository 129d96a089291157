/// @file TetherCore.h
/// TetherCore: what every Tether Arduino library shares, in one library so that a sketch can use several
/// (TetherRomi on `Serial` to the host and TetherElcano's ring on a SoftwareSerial, a `tether generate`
/// library beside either) and link the shared code once: Tether's portable core (tether/core/: CRCs,
/// status, session pieces) and the Arduino glue (TetherArduinoStream.h: runs of bytes on the core's serial
/// rings; TetherSetArduinoMacrosAside.h / TetherRestoreArduinoMacros.h).
///
/// Sketches need not include it: the other libraries' headers do, first, which is how the Arduino builder
/// finds this library (by a header at its src/ root; library.properties' `depends=` only tells the Library
/// Manager what to install). Installed from TetherCore.zip like the others, and needed by all of them.
#pragma once

/// TetherCore's version (major * 10000 + minor * 100 + patch), as in its library.properties.
#define TETHER_CORE_VERSION 300
