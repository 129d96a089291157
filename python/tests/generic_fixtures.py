"""The generic fixtures of the binding's tests, a pytest plugin module loaded with ``-p generic_fixtures`` by
every Python test (python/tests/CMakeLists.txt), here and in the codecs' plugin folders (a conftest.py would
serve the tests of its own folder only). Each codec's own (its boards, its clients) are in its plugin's
fixtures module (tether_codec_plugin's PYTHON_FIXTURES, cmake/codec-plugin.cmake)."""

import os
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


class LinkEvents:
    """A transport's link events as they come (``transport.on_link_event``); ``wait(n)`` returns the n-th,
    waiting for it (the limit only bounds a hang: nothing sleeps)."""

    def __init__(self, transport):
        self.items = []
        self.changed = threading.Condition()
        transport.on_link_event(self.add)

    def add(self, event):
        with self.changed:
            self.items.append(event)
            self.changed.notify_all()

    def wait(self, count):
        with self.changed:
            assert self.changed.wait_for(lambda: len(self.items) >= count, timeout=30), self.items
            return self.items[count - 1]


class UnpluggableBoard:
    """A virtual Uno behind a stable name (a symlink, as /dev/serial/by-id gives one): ``unplug()`` removes
    the name and closes the board; ``plug_in()`` puts a new board running the same image behind it (a board
    plugged in again boots afresh). ``board`` is the one plugged in now."""

    def __init__(self, directory, image, **options):
        self.link = str(directory / "usb-Tether_Uno-if00")
        self.image, self.options = image, options
        self.boards = []
        self.board = None
        self.plug_in()

    def plug_in(self):
        self.board = tether.VirtualUno(self.image, **self.options)
        self.boards.append(self.board)
        os.symlink(self.board.port, self.link)

    def unplug(self):
        os.unlink(self.link)
        self.board.close()

    def close(self):
        for board in self.boards:
            board.close()


@pytest.fixture
def unpluggable(tmp_path):
    """``unpluggable(image, **VirtualUno options)``: an UnpluggableBoard, closed after the test."""
    made = []

    def make(image, **options):
        made.append(UnpluggableBoard(tmp_path, image, **options))
        return made[-1]

    yield make
    for board in made:
        board.close()


@pytest.fixture
def link_events():
    """``link_events(transport)``: a LinkEvents collecting the transport's link events."""
    return LinkEvents
