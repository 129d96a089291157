// avr-libc/libgcc have no __cxa_pure_virtual, which the vtables of abstract classes (IInputStream,
// IOutputStream, IRomiSerial) may reference. Calling a pure virtual function is a bug: reset the MCU
// rather than run on. The Arduino core has its own (abi.cpp), so this one is for the bare-metal build.
#if defined(__AVR__) && !defined(ARDUINO)

#include "tether/firmware/reset.hpp"

extern "C" void __cxa_pure_virtual() { tether::firmware::system_reset(); }

#endif
