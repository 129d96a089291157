"""The Romi codec's pytest fixtures: romi-test boards (real-time pacing, like hardware) and a client on one.
A pytest plugin module (tether_codec_plugin's PYTHON_FIXTURES), loaded with ``-p romi_fixtures`` by every
Python test: the binding's own tests (python/tests) call through Romi clients too.

Clients are opened on the board itself (``tether.romi.Client(board)``): their deadlines run on the board's
simulated time, so a loaded machine that slows the simulation cannot time a call out before the device has
had its time (with the wall clock, a call to a real-time board timed out once that way at load ~5)."""

import pytest

import tether


@pytest.fixture
def romi_board(report_board):
    with tether.VirtualUno("romi-test", seed=1) as board:
        yield board
        report_board(board)


@pytest.fixture
def romi_client(romi_board):
    with tether.romi.Client(romi_board) as client:
        yield client


@pytest.fixture
def held_board(report_board):
    """A romi-test board that moves only when the test advances it (``run_for``)."""
    with tether.VirtualUno("romi-test", seed=1, start=False) as board:
        yield board
        report_board(board)
