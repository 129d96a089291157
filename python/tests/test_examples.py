"""examples/python/blink.py and analogread.py, run against virtual romi-blink and romi-analogread boards (a
bounded number of iterations).

The programs are RomiSerial's, unchanged but for their import, and are run as a user runs them
(``python3 blink.py PORT``), but in this process (runpy, with their argv): they open the board's pty by its
path, and a client that opens an in-process board's pty runs on that board's clock, so a loaded machine
that slows the simulation cannot time their calls out."""

import os
import runpy
import sys
import threading

import pytest

import tether

EXAMPLES = os.path.join(os.path.dirname(__file__), "..", "..", "examples", "python")


def run_example(monkeypatch, capsys, name, *args):
    """Runs the example as ``python3 <name> *args`` would, in this process; returns what it printed."""
    path = os.path.join(EXAMPLES, name)
    monkeypatch.setattr(sys, "argv", [path, *args])
    runpy.run_path(path, run_name="__main__")
    return capsys.readouterr().out


def test_blink_turns_the_led_on_and_off(monkeypatch, capsys):
    with tether.VirtualUno("romi-blink") as board:
        assert run_example(monkeypatch, capsys, "blink.py", board.port, "2", "0.3").strip() == "blinked 2 times"
        assert not board.pin(13).level  # the last command turned it off
        # And the LED follows the command, through the same compat class the example uses (on the board
        # itself: its UART and its clock).
        from tether.compat import ControlSerial
        with ControlSerial(board) as serial:
            assert serial.execute('L', 1) == [0]
            assert board.pin(13).level
            assert serial.execute('L', 0) == [0]
            assert not board.pin(13).level


def test_analogread_prints_the_sensor_value(monkeypatch, capsys):
    with tether.VirtualUno("romi-analogread") as board:
        board.set_analog_input(0, 2.5)  # half of AVcc: 511 or 512
        lines = run_example(monkeypatch, capsys, "analogread.py", board.port, "3", "0.05").strip().splitlines()
        assert len(lines) == 3
        for line in lines:
            assert line.startswith("sensor value: ")
            assert abs(int(line.split(": ")[1]) - 512) <= 1


def test_a_client_opened_on_a_boards_pty_path_runs_on_the_boards_clock():
    # What the examples rely on. A client on the board's clock is closed with the board (a stopped board's
    # time stands still): its pending call raises ClosedError at once. On the wall clock it was left to the
    # pty's hang-up or its own window, and the client stayed open.
    with tether.VirtualUno("romi-test") as board:
        client = tether.romi.Client(board.port, boot_wait=0, attempt_timeout=5.0, call_budget=10.0)
        outcome = {}

        def call():
            try:
                outcome["result"] = client.call("w", 3000)  # busy for 3 s of board time
            except Exception as error:  # noqa: BLE001 - the test inspects it
                outcome["error"] = error

        caller = threading.Thread(target=call)
        caller.start()
        caller.join(0.2)
        board.close()
        assert not client.is_open
        caller.join(60)
        assert isinstance(outcome.get("error"), tether.ClosedError), outcome


def test_control_serial_raises_on_device_errors():
    from tether.compat import ControlSerial
    with tether.VirtualUno("romi-blink") as board:
        with ControlSerial(board) as serial:
            serial.set_debug(True)
            with pytest.raises(tether.RomiError) as caught:
                serial.execute('Z')
            assert caught.value.code == -16
