#!/usr/bin/env python3
"""Blink: the RomiSerial README's Python example on Tether (only the import line differs).

Turns the LED of a board running romi-blink (firmware/romi-blink) on and off every second.
Usage: blink.py [PORT] [ITERATIONS]   (default /dev/ttyACM0, forever)
"""

import sys
import time

from tether.compat import ControlSerial  # RomiSerial: from romiserial.device import ControlSerial

device = sys.argv[1] if len(sys.argv) > 1 else "/dev/ttyACM0"
iterations = int(sys.argv[2]) if len(sys.argv) > 2 else None
period = float(sys.argv[3]) if len(sys.argv) > 3 else 1.0

serial = ControlSerial(device)
count = 0
while iterations is None or count < iterations:
    serial.execute('L', 1)
    time.sleep(period)
    serial.execute('L', 0)
    time.sleep(period)
    count += 1
print(f"blinked {count} times")
