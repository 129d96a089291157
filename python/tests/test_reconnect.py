"""A serial port that vanishes and comes back: calls raise DisconnectedError meanwhile, the link events and
counters tell the outage, the first call after the return is answered. The port is a stable name (a symlink,
as /dev/serial/by-id gives one) for a virtual Uno's pty; the Uno goes away and another one takes the name.
Nothing sleeps: the test waits for the events (a generous limit only bounds a hang)."""

import os
import threading

import pytest

import tether


class Events:
    def __init__(self):
        self.items = []
        self.changed = threading.Condition()

    def add(self, event):
        with self.changed:
            self.items.append(event)
            self.changed.notify_all()

    def wait(self, count):
        with self.changed:
            assert self.changed.wait_for(lambda: len(self.items) >= count, timeout=30), self.items
            return self.items[count - 1]


def test_a_serial_port_that_comes_back_behind_its_name(tmp_path):
    link = tmp_path / "usb-Tether_Uno-if00"
    first = tether.VirtualUno("romi-test")
    second = None
    os.symlink(first.port, link)
    transport = tether.transports.serial(str(link), boot_wait=0)
    events = Events()
    transport.on_link_event(events.add)
    client = tether.romi.Client(transport)
    try:
        assert client.call("e") == [0, 1, 2]
        os.unlink(link)
        first.close()  # unplugged
        down = events.wait(1)
        assert down["kind"] == "down" and str(link) in down["reason"]
        with pytest.raises(tether.DisconnectedError) as caught:
            client.call("e")
        assert isinstance(caught.value, ConnectionError) and isinstance(caught.value, tether.TransportError)
        assert transport.link_counters()["up"] is False

        second = tether.VirtualUno("romi-test")
        os.symlink(second.port, link)
        up = events.wait(2)
        assert up["kind"] == "up" and up["down_ms"] >= 0 and up["path"] == str(link)
        assert client.call("e") == [0, 1, 2]
        counters = transport.link_counters()
        assert counters["disconnects"] == 1 and counters["reconnects"] == 1 and counters["up"] is True
        assert counters["gave_up"] is False
    finally:
        client.close()
        first.close()
        if second is not None:
            second.close()


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
