"""A serial port that vanishes and comes back: calls raise DisconnectedError meanwhile, the link events and
counters tell the outage, the first call after the return is answered. The port is a stable name (a symlink,
as /dev/serial/by-id gives one) for a virtual Uno's pty; the Uno goes away and another one takes the name.
Nothing sleeps: the test waits for the events (a generous limit only bounds a hang)."""

import os

import pytest

import tether


def test_a_serial_port_that_comes_back_behind_its_name(unpluggable, link_events):
    board = unpluggable("romi-test")
    link = board.link
    transport = tether.transports.serial(link, boot_wait=0)
    events = link_events(transport)
    client = tether.romi.Client(transport)
    try:
        assert client.call("e") == [0, 1, 2]
        board.unplug()
        down = events.wait(1)
        assert down["kind"] == "down" and link in down["reason"]
        with pytest.raises(tether.DisconnectedError) as caught:
            client.call("e")
        assert isinstance(caught.value, ConnectionError) and isinstance(caught.value, tether.TransportError)
        assert transport.link_counters()["up"] is False

        board.plug_in()
        up = events.wait(2)
        assert up["kind"] == "up" and up["down_ms"] >= 0 and up["path"] == link
        assert client.call("e") == [0, 1, 2]
        counters = transport.link_counters()
        assert counters["disconnects"] == 1 and counters["reconnects"] == 1 and counters["up"] is True
        assert counters["gave_up"] is False
    finally:
        client.close()


def test_without_reconnect_the_link_fails_for_good(tmp_path):
    link = tmp_path / "usb-Tether_Uno-if00"
    board = tether.VirtualUno("romi-test")
    os.symlink(board.port, link)
    transport = tether.transports.serial(str(link), boot_wait=0, reconnect=False)
    client = tether.romi.Client(transport)
    try:
        assert client.call("e") == [0, 1, 2]
        board.close()
        with pytest.raises(Exception) as caught:
            for _ in range(100):  # the first call may still be written before the loss is read
                client.call("e")
        assert not isinstance(caught.value, tether.DisconnectedError)
        assert transport.link_counters()["disconnects"] == 0
    finally:
        client.close()
        board.close()


def test_link_api_of_other_transports():
    transport = tether.transports.pty()
    assert transport.link_counters() is None
    with pytest.raises(ValueError):
        transport.on_link_event(print)
