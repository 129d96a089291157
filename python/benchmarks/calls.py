#!/usr/bin/env python3
"""Romi calls per second through the Python binding vs the same calls from C++ (tether_python_calls_cpp),
each on its own virtual romi-test board (same image, same pacing), through the board's pty as a serial
port. Runs both alternately ROUNDS times and prints the medians and the binding's cost per call.

Usage: PYTHONPATH=build/python python3 python/benchmarks/calls.py BUILD_DIR [CALLS] [ROUNDS] [fast|real_time]
"""

import os
import statistics
import subprocess
import sys
import time

import tether


def python_rate(image, calls, pacing):
    with tether.VirtualUno(image, fast=(pacing == "fast")) as board:
        with tether.romi.Client(board.port, boot_wait=0) as client:
            client.call("a")
            start = time.perf_counter()
            for _ in range(calls):
                client.call("a")
            return calls / (time.perf_counter() - start)


def cpp_rate(build, image, calls, pacing):
    program = os.path.join(build, "python", "benchmarks", "tether_python_calls_cpp")
    output = subprocess.run([program, image, str(calls), pacing], check=True, capture_output=True, text=True).stdout
    return float(output.split()[1])


def main():
    build = sys.argv[1]
    calls = int(sys.argv[2]) if len(sys.argv) > 2 else 500
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 5
    pacing = sys.argv[4] if len(sys.argv) > 4 else "fast"
    image = os.path.join(tether.firmware_dir(), "romi-test.elf")
    py, cpp = [], []
    for _ in range(rounds):
        cpp.append(cpp_rate(build, image, calls, pacing))
        py.append(python_rate(image, calls, pacing))
    py_rate, cpp_rate_ = statistics.median(py), statistics.median(cpp)
    extra = (1 / py_rate - 1 / cpp_rate_) / (1 / cpp_rate_) * 100
    print(f"pacing {pacing}, {calls} calls x {rounds} rounds (medians)")
    print(f"  C++:    {cpp_rate_:8.1f} calls/s  ({1e6 / cpp_rate_:7.1f} us/call)  runs {[round(x) for x in cpp]}")
    print(f"  Python: {py_rate:8.1f} calls/s  ({1e6 / py_rate:7.1f} us/call)  runs {[round(x) for x in py]}")
    print(f"  binding adds {extra:+.1f} % per call")


if __name__ == "__main__":
    main()
