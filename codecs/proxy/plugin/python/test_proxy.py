"""tether.proxy.Client, primary and compat modes, against the proxy images on virtual Unos."""

import threading
import time

import pytest

import tether


def wait_for(predicate, seconds=5.0):
    limit = time.monotonic() + seconds
    while time.monotonic() < limit:
        if predicate():
            return True
        time.sleep(0.01)
    return predicate()


def test_primary_servo_and_digital_are_acked_and_reach_the_pins():
    events = []
    established = threading.Event()

    def on_event(event):
        events.append(event)
        if event.kind == "session_established":
            established.set()

    with tether.VirtualUno("proxy", seed=2) as board:
        with tether.proxy.Client(board, on_event=on_event) as client:
            assert not client.compat
            result = client.servo(9).init(90)
            assert result.acked and result.message_id != 0 and result.attempts >= 1
            assert client.servo(9).set(120).acked
            assert client.digital(13).init(False).acked
            assert client.digital(13).set(True).acked
            assert wait_for(lambda: board.pin(13).level)
            assert established.is_set()
            assert client.session().established
            counters = client.counters()
            assert counters.acks >= 4
            assert counters.resets_sent >= 1
            states = {state.pin: state for state in client.pin_states()}
            assert states[9].pin_kind == "servo"


def test_compat_mode_writes_without_acks():
    with tether.VirtualUno("proxy-compat", seed=3) as board:
        with tether.proxy.Client(board, compat=True) as client:
            assert client.compat
            client.digital(7).init(False)
            result = client.digital(7).set(True)
            assert not result.acked  # compat: completes when written
            assert wait_for(lambda: board.pin(7).level)
            assert client.counters().link.crc_errors == 0


def test_reset_failsafe_is_primary_only():
    with tether.VirtualUno("proxy-compat", seed=3) as board:
        with tether.proxy.Client(board, compat=True) as client:
            with pytest.raises(tether.ProxyMessageError) as caught:
                client.reset_failsafe()
            assert caught.value.code == 4  # wrong_mode
            assert isinstance(caught.value, ValueError)


def test_a_board_plugged_in_again_gets_a_new_session_with_the_inits_replayed(unpluggable, link_events):
    # The new board knows no pin: the servo and the output work on it only because the client ran the
    # handshake again when the port came back and replayed the inits of the first session.
    sessions = []
    established = threading.Condition()

    def on_event(event):
        if event.kind == "session_established":
            with established:
                sessions.append(event)
                established.notify_all()

    board = unpluggable("proxy", seed=2)
    transport = tether.transports.serial(board.link, boot_wait=0)
    events = link_events(transport)
    with tether.proxy.Client(transport, on_event=on_event) as client:
        assert client.servo(9).init(90).acked
        assert client.digital(13).init(False).acked
        with established:
            assert established.wait_for(lambda: len(sessions) >= 1, timeout=30)
        board.unplug()
        assert events.wait(1)["kind"] == "down"
        board.plug_in()
        assert events.wait(2)["kind"] == "up"
        with established:
            assert established.wait_for(lambda: len(sessions) >= 2, timeout=30), sessions
        assert client.digital(13).set(True).acked
        assert wait_for(lambda: board.board.pin(13).level)
        assert client.servo(9).set(120).acked
        assert client.counters().inits_replayed >= 2
        assert transport.link_counters()["reconnects"] == 1
