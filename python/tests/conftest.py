"""Fixtures of the binding's tests: virtual boards of every codec (real-time pacing, like hardware)."""

import pytest

import tether


@pytest.fixture
def romi_board():
    with tether.VirtualUno("romi-test", seed=1) as board:
        yield board


@pytest.fixture
def romi_client(romi_board):
    # A pty from a virtual board has no DTR reset: no boot wait.
    with tether.romi.Client(romi_board.port, boot_wait=0) as client:
        yield client
