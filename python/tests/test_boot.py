"""How a client's serial port waits for the board's boot (``boot=``, a configuration's ``"boot"``): detect,
fixed or none, and what the port reports (``link_counters()``: ``boot``, ``ready_after_ms``). The boards are
virtual Unos on ptys, which do not reset when opened: a Romi board is found booted by the probe sent once the
line was quiet for 1.2 s. Bad values are ValueErrors before anything opens."""

import json

import pytest

import tether


def rover_file(tmp_path, port, **serial):
    path = tmp_path / "rover.json"
    transport = {"serial": {"path": port, "reconnect": False, **serial}}
    path.write_text(json.dumps({"devices": [{"name": "board", "codec": "romi", "transport": transport}]}))
    return str(path)


def test_a_romi_device_detects_the_boot_by_default_and_reports_when_it_was_ready(tmp_path):
    with tether.VirtualUno("romi-test") as board:
        rover = tether.open_rover(rover_file(tmp_path, board.port, boot_wait_ms=10000))
        try:
            counters = rover.link_counters("board")
            assert counters["boot"] == "probed"
            assert 1200 <= counters["ready_after_ms"] < 10000  # after 1.2 s of quiet, not at the bound
            assert rover.romi("board").call("e") == [0, 1, 2]
        finally:
            rover.close()


@pytest.mark.parametrize("mode, outcome, least_ms", [("fixed", "waited", 300), ("none", "immediate", 0)])
def test_fixed_and_none_from_a_configuration(tmp_path, mode, outcome, least_ms):
    with tether.VirtualUno("romi-test") as board:
        rover = tether.open_rover(rover_file(tmp_path, board.port, boot_wait_ms=300, boot=mode))
        try:
            counters = rover.link_counters("board")
            assert counters["boot"] == outcome
            assert counters["ready_after_ms"] >= least_ms
            assert rover.romi("board").call("e") == [0, 1, 2]
        finally:
            rover.close()


@pytest.mark.parametrize("mode", ["detect", "fixed", "none"])
def test_the_clients_boot_keyword(mode):
    with tether.VirtualUno("romi-test") as board:
        with tether.romi.Client(board.port, boot=mode, boot_wait=5.0 if mode == "detect" else 0.2) as client:
            assert client.call("e") == [0, 1, 2]


def test_bad_boot_values_are_value_errors():
    with tether.VirtualUno("romi-test") as board:
        with pytest.raises(ValueError, match="boot must be 'detect', 'fixed' or 'none', got 'sometimes'"):
            tether.romi.Client(board.port, boot="sometimes")
        # A bare port knows no codec, nor does proxy-compat's firmware announce its boot.
        with pytest.raises(ValueError, match="needs a codec"):
            tether.transports.serial(board.port, boot="detect")
        with pytest.raises(ValueError, match="needs a codec"):
            tether.proxy.Client(board.port, compat=True, boot="detect")
        # Elcano boards announce nothing either, and no request is answered by every board of a ring.
        with pytest.raises(ValueError, match="needs a codec"):
            tether.elcano.RingClient(board.port, boot="detect")
        with pytest.raises(ValueError, match="got 'later'"):
            tether.elcano.RingClient(board.port, boot="later")


def test_an_elcano_ring_client_takes_boot_fixed_or_none():
    with tether.VirtualUno("elcano-node") as board:
        # The board, configured for nothing, forwards every message: the request comes back round the ring,
        # which shows the port carried it both ways after the wait.
        for mode in ("none", "fixed"):
            with tether.elcano.RingClient(board.port, boot=mode, boot_wait=0.2) as client:
                with pytest.raises(tether.elcano.ElcanoError, match="came back round the ring"):
                    client.request(tether.elcano.Message(type="drive", speed=50, angle=25), reply_type="sensor")
