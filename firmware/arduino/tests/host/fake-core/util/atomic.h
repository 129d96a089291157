// Host stand-in for avr-libc's <util/atomic.h> (arduino_glue_test): the host has no interrupts, so an
// atomic block is a plain block; the fake core's interrupt handlers run only when a test calls them.
#pragma once

#define ATOMIC_RESTORESTATE 0
#define ATOMIC_BLOCK(type) for (int tether_fake_atomic_once = 1; tether_fake_atomic_once != 0; tether_fake_atomic_once = 0)
