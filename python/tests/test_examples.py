"""examples/python/blink.py and analogread.py, run as programs against virtual romi-blink and
romi-analogread boards (a bounded number of iterations).

The programs are RomiSerial's, unchanged but for their import: they open the board's pty by its path in a
process of their own, so their calls run on the wall clock (another process cannot share the board's);
the in-process checks open ControlSerial on the board itself, on its clock."""

import os
import subprocess
import sys

import pytest

import tether

EXAMPLES = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "python")


def run_example(name, *args):
    return subprocess.run([sys.executable, os.path.join(EXAMPLES, name), *args], capture_output=True, text=True,
                          timeout=120, env=os.environ.copy())


def test_blink_turns_the_led_on_and_off():
    with tether.VirtualUno("romi-blink") as board:
        result = run_example("blink.py", board.port, "2", "0.3")
        assert result.returncode == 0, result.stderr
        assert result.stdout.strip() == "blinked 2 times"
        assert not board.pin(13).level  # the last command turned it off
        # And the LED follows the command, through the same compat class the example uses (on the board
        # itself: its UART and its clock).
        from tether.compat import ControlSerial
        with ControlSerial(board) as serial:
            assert serial.execute('L', 1) == [0]
            assert board.pin(13).level
            assert serial.execute('L', 0) == [0]
            assert not board.pin(13).level


def test_analogread_prints_the_sensor_value():
    with tether.VirtualUno("romi-analogread") as board:
        board.set_analog_input(0, 2.5)  # half of AVcc: 511 or 512
        result = run_example("analogread.py", board.port, "3", "0.05")
        assert result.returncode == 0, result.stderr
        lines = result.stdout.strip().splitlines()
        assert len(lines) == 3
        for line in lines:
            assert line.startswith("sensor value: ")
            assert abs(int(line.split(": ")[1]) - 512) <= 1


def test_control_serial_raises_on_device_errors():
    from tether.compat import ControlSerial
    with tether.VirtualUno("romi-blink") as board:
        with ControlSerial(board) as serial:
            serial.set_debug(True)
            with pytest.raises(tether.RomiError) as caught:
                serial.execute('Z')
            assert caught.value.code == -16
