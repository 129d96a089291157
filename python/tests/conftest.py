"""Fixtures of the binding's tests: virtual boards of every codec (real-time pacing, like hardware)."""

import pytest

import tether


@pytest.fixture
def romi_board():
    with tether.VirtualUno("romi-test", seed=1) as board:
        yield board


# Romi timing for tests that are not about timeouts: the boards run in real time, and on a loaded machine a
# simulation can fall behind the wall clock by more than the spec's 1 s window (a call to a virtual board timed
# out once that way at load ~5). Windows this long only bound a hang; tests of timeouts set their own.
PATIENT_ROMI = {"attempt_timeout": 10.0, "call_budget": 20.0}


@pytest.fixture
def patient_romi():
    """Keyword arguments for romi.Client / ControlSerial in tests that are not about timeouts."""
    return dict(PATIENT_ROMI)


@pytest.fixture
def romi_client(romi_board):
    # A pty from a virtual board has no DTR reset: no boot wait.
    with tether.romi.Client(romi_board.port, boot_wait=0, **PATIENT_ROMI) as client:
        yield client
