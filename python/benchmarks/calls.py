#!/usr/bin/env python3
"""Romi calls per second through the Python binding vs the same calls from C++ (tether_python_calls_cpp),
alternately, ROUNDS times each; prints the best run of each (the least disturbed by other load), the
process's CPU time per call (caller + io thread; best run), and the binding's cost per call. Two devices:
  board  a virtual romi-test board (same image, same pacing for both), through its pty as a serial port
  fake   a Romi device that answers at once (tether_python_calls_cpp --fake-device, no simulator) on a
         pty: what is left of a call is the client's own cost, so the binding's share shows best

Usage: PYTHONPATH=build/python python3 python/benchmarks/calls.py BUILD_DIR [CALLS] [ROUNDS] [board|fake]
                                                                            [fast|real_time]
"""

import os
import subprocess
import sys
import time

import tether


def timed(client, calls):
    """(calls per second, CPU microseconds per call of this process: caller and io thread)."""
    client.call("a")  # warm-up
    cpu_start = time.process_time()
    start = time.perf_counter()
    for _ in range(calls):
        client.call("a")
    elapsed = time.perf_counter() - start
    return calls / elapsed, (time.process_time() - cpu_start) * 1e6 / calls


def rate_from(output):
    fields = output.split()
    return float(fields[1]), float(fields[3])


class FakeDevice:
    """tether_python_calls_cpp --fake-device for the time of a `with` block (stops when its stdin closes)."""

    def __init__(self, program):
        self.process = subprocess.Popen([program, "--fake-device"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                        text=True)
        line = self.process.stdout.readline()
        if not line.startswith("PTY "):
            raise RuntimeError("the fake device gave no port: " + line)
        self.port = line.split()[1]

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.process.stdin.close()
        self.process.wait(timeout=10)


def python_rate(program, device, image, calls, pacing):
    if device == "fake":
        with FakeDevice(program) as fake, tether.romi.Client(fake.port, boot_wait=0) as client:
            return timed(client, calls)
    with tether.VirtualUno(image, fast=(pacing == "fast")) as board:
        with tether.romi.Client(board.port, boot_wait=0) as client:
            return timed(client, calls)


def cpp_rate(program, device, image, calls, pacing):
    if device == "fake":
        with FakeDevice(program) as fake:
            run = subprocess.run([program, "--port", fake.port, str(calls)], check=True, capture_output=True, text=True)
            return rate_from(run.stdout)
    run = subprocess.run([program, image, str(calls), pacing], check=True, capture_output=True, text=True)
    return rate_from(run.stdout)


def main():
    build = sys.argv[1]
    calls = int(sys.argv[2]) if len(sys.argv) > 2 else 500
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 5
    device = sys.argv[4] if len(sys.argv) > 4 else "board"
    pacing = sys.argv[5] if len(sys.argv) > 5 else "fast"
    if device not in ("board", "fake") or pacing not in ("fast", "real_time"):
        sys.exit(__doc__)
    program = os.path.join(build, "python", "benchmarks", "tether_python_calls_cpp")
    image = os.path.join(tether.firmware_dir(), "romi-test.elf")
    py, cpp = [], []
    for _ in range(rounds):
        cpp.append(cpp_rate(program, device, image, calls, pacing))
        py.append(python_rate(program, device, image, calls, pacing))
    py_best, cpp_best = max(rate for rate, _ in py), max(rate for rate, _ in cpp)
    py_cpu, cpp_cpu = min(cpu for _, cpu in py), min(cpu for _, cpu in cpp)
    extra = (1 / py_best - 1 / cpp_best) / (1 / cpp_best) * 100
    what = "fake device (no simulator)" if device == "fake" else f"virtual romi-test, pacing {pacing}"
    print(f"{what}: {calls} calls x {rounds} rounds (best run)")
    for name, best, cpu, runs in (("C++", cpp_best, cpp_cpu, cpp), ("Python", py_best, py_cpu, py)):
        print(f"  {name + ':':7} {best:8.1f} calls/s ({1e6 / best:7.1f} us/call), CPU {cpu:6.1f} us/call  "
              f"runs {[round(rate) for rate, _ in runs]}")
    print(f"  binding adds {extra:+.1f} % per call ({1e6 / py_best - 1e6 / cpp_best:+.1f} us), "
          f"CPU {py_cpu - cpp_cpu:+.1f} us/call ({(py_cpu - cpp_cpu) / cpp_cpu * 100:+.1f} %)")


if __name__ == "__main__":
    main()
