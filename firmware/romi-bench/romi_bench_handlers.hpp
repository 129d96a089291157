/// @file romi_bench_handlers.hpp
/// The four handlers of the Romi cycle measurements (a, e, c, d), shared by the romi-bench image
/// (closed loop on the virtual Uno) and the bench-codecs image (one request in memory), so both measure
/// the same device. They do no work of their own: what is measured is the device.
///   a: no argument, `[0]` | e: no argument, `[0,1,2]` | c: two integers, `[0]` | d: a string, `[0]`
#pragma once

#include "RomiSerial.h"

namespace romi_bench {

inline void ok(romiserial::IRomiSerial* romi, int16_t*, const char*) { romi->send_ok(); }
inline void values(romiserial::IRomiSerial* romi, int16_t*, const char*) { romi->send("[0,1,2]"); }

/// The handler table.
const romiserial::MessageHandler kHandlers[] = {
    {'a', 0, false, ok},
    {'e', 0, false, values},
    {'c', 2, false, ok},
    {'d', 0, true, ok},
};
/// Its size.
constexpr uint8_t kHandlerCount = sizeof(kHandlers) / sizeof(kHandlers[0]);

}  // namespace romi_bench
