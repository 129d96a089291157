"""The generic fixtures of the binding's tests, a pytest plugin module loaded with ``-p generic_fixtures`` by
every Python test (python/tests/CMakeLists.txt), here and in the codecs' plugin folders (a conftest.py would
serve the tests of its own folder only). Each codec's own (its boards, its clients) are in its plugin's
fixtures module (tether_codec_plugin's PYTHON_FIXTURES, cmake/codec-plugin.cmake)."""

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
def report_board(request):
    """``report_board(board)`` after a board fixture's test (its teardown): prints the board's side of the
    story if the test failed (the codecs' board fixtures call it)."""
    return lambda board: print_board_if_failed(request, board)


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
