"""Fixtures of the binding's tests: virtual boards of every codec (real-time pacing, like hardware).

Clients are opened on the board itself (``tether.romi.Client(board)``): their deadlines run on the board's
simulated time, so a loaded machine that slows the simulation cannot time a call out before the device has
had its time (with the wall clock, a call to a real-time board timed out once that way at load ~5)."""

import threading

import pytest

import tether


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    report = (yield).get_result()
    if report.when == "call":
        item.call_failed = report.failed


def print_board_if_failed(request, board):
    """After a failed test, the board's side of the story (teardown output, shown with the failure): a
    call that timed out with no byte received means the request never reached the board, bytes sent
    mean it answered and the answer was not taken in time."""
    if getattr(request.node, "call_failed", False):
        try:
            print(f"board after the failure: {board.simulated_time:.3f} s of board time, {board.stats()}")
        except tether.ClosedError:
            print("board after the failure: closed")


@pytest.fixture
def romi_board(request):
    with tether.VirtualUno("romi-test", seed=1) as board:
        yield board
        print_board_if_failed(request, board)


@pytest.fixture
def romi_client(romi_board):
    with tether.romi.Client(romi_board) as client:
        yield client


@pytest.fixture
def held_board(request):
    """A romi-test board that moves only when the test advances it (``run_for``)."""
    with tether.VirtualUno("romi-test", seed=1, start=False) as board:
        yield board
        print_board_if_failed(request, board)


class Call(threading.Thread):
    """A blocking call on a thread of its own, so that the test can advance a held board meanwhile."""

    def __init__(self, function, *args):
        super().__init__(daemon=True)
        self.function, self.args = function, args
        self.result = self.error = None
        self.start()

    def run(self):
        try:
            self.result = self.function(*self.args)
        except Exception as error:  # the test asserts on it
            self.error = error


@pytest.fixture
def call_in_thread():
    return Call
