#!/usr/bin/env python3
"""AnalogRead: the RomiSerial README's Python example on Tether (only the import line differs).

Prints the value of analog input A0 of a board running romi-analogread (firmware/romi-analogread).
Usage: analogread.py [PORT] [ITERATIONS]   (default /dev/ttyACM0, forever)
"""

import sys
import time

from tether.compat import ControlSerial  # RomiSerial: from romiserial.device import ControlSerial

device = sys.argv[1] if len(sys.argv) > 1 else "/dev/ttyACM0"
iterations = int(sys.argv[2]) if len(sys.argv) > 2 else None
period = float(sys.argv[3]) if len(sys.argv) > 3 else 0.1

serial = ControlSerial(device)
count = 0
while iterations is None or count < iterations:
    response = serial.execute('A')
    print(f"sensor value: {response[1]}")
    time.sleep(period)
    count += 1
