"""tether.elcano.RingClient on a virtual ring of three elcano-node boards, opened from a rover config."""

import json
import os
import threading
import tty

import pytest

import tether

RING = {
    "name": "python-ring",
    "devices": [{
        "name": "ring",
        "codec": "elcano",
        "transport": {"virtual_ring": {"pacing": "real_time", "seed": 4, "boards": [
            {"firmware": "elcano-node",
             "eeprom": {"capture": ["goal"], "behaviours": ["answer_goal_with_segment"]}},
            {"firmware": "elcano-node",
             "eeprom": {"capture": ["sensor", "segment"],
                        "behaviours": ["answer_segment_with_drive", "answer_sensor_with_drive"]}},
            {"firmware": "elcano-node",
             "eeprom": {"capture": ["drive"], "behaviours": ["drive_servos", "report_drive_as_sensor"]}},
        ]}},
        "options": {"generation": "B", "capture": ["sensor"]},
    }],
}


@pytest.fixture
def ring_rover(tmp_path):
    path = tmp_path / "ring.json"
    path.write_text(json.dumps(RING))
    with tether.open_rover(path) as rover:
        yield rover


def test_drive_request_is_answered_by_a_sensor_report(ring_rover):
    ring = ring_rover.elcano("ring")
    reply = ring.request(tether.elcano.Message(type="drive", speed=50, angle=25), reply_type="sensor")
    assert reply.type == "sensor"
    assert reply.speed == 50 and reply.angle == 25
    counters = ring.counters()
    assert counters.replies == 1
    assert counters.ring.originated >= 1


def test_message_fields_and_wire_form():
    drive = tether.elcano.Message(type="D", speed=50, angle=25)
    assert drive.type == "drive" and drive.number is None
    assert drive.to_wire("B") == b"D{s 50}{a 25}\n"
    assert drive == tether.elcano.Message(type="drive", angle=25, speed=50)
    assert repr(drive) == "Message(type='drive', speed=50, angle=25)"


def test_rover_lists_devices_and_rejects_the_wrong_codec(ring_rover):
    assert [(d.name, d.codec) for d in ring_rover.devices] == [("ring", "elcano")]
    with pytest.raises(KeyError):
        ring_rover.romi("ring")
    with pytest.raises(KeyError):
        ring_rover.elcano("nope")


def test_closed_rover_closes_its_clients(ring_rover):
    ring = ring_rover.elcano("ring")
    ring_rover.close()
    with pytest.raises(tether.ClosedError):
        ring.request(tether.elcano.Message(type="drive", speed=1, angle=2), reply_type="sensor")


def _read_line(fd):
    data = b""
    while not data.endswith(b"\n"):
        chunk = os.read(fd, 64)
        assert chunk, "the pty closed"
        data += chunk
    return data


def test_ring_client_on_a_pty_port_requests_forwards_and_receives():
    # The test plays the rest of the ring on the pty's other end: what the host sends arrives there, and what
    # the test writes is what the last board would send to the host.
    transport = tether.transports.pty()
    path = transport.path
    Message = tether.elcano.Message
    reading = Message(type="sensor", speed=50, angle=25, east=10, north=20, bearing=90)
    with tether.elcano.RingClient(transport, capture=("sensor",)) as ring:
        fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        try:
            tty.setraw(fd)

            def rest_of_ring():
                assert _read_line(fd) == b"D{s 50}{a 25}\n"
                os.write(fd, reading.to_wire("B"))

            board = threading.Thread(target=rest_of_ring)
            board.start()
            assert ring.request(Message(type="drive", speed=50, angle=25), reply_type="sensor") == reading
            board.join()
            # A type the host does not capture goes on round the ring (without its spaces, like the reference).
            goal = Message(type="goal", number=3, east=1, north=2, bearing=4).to_wire("B")
            os.write(fd, goal)
            assert _read_line(fd) == goal.replace(b" ", b"")
            # A captured type no request awaits waits for receive().
            os.write(fd, reading.to_wire("B"))
            assert ring.receive(timeout=5.0) == reading
            counters = ring.counters()
            assert counters.replies == 1
            assert counters.link.frames_ok == 3
        finally:
            os.close(fd)


def test_ring_client_on_a_virtual_boards_port_reports_an_undeliverable_request():
    # One unconfigured elcano-node forwards everything: the drive comes back to the host, no node took it.
    with tether.VirtualUno("elcano-node") as board:
        with tether.elcano.RingClient(board) as ring:
            with pytest.raises(tether.ElcanoError) as caught:
                ring.request(tether.elcano.Message(type="drive", speed=5, angle=2), reply_type="sensor")
            assert caught.value.code == 2  # undeliverable
            assert ring.counters().link.frames_ok >= 1


def test_ring_events_carry_only_the_fields_of_their_kind():
    # Regression: a link_failed event carried a dummy Message(type='drive'), an undeliverable one error='success'.
    events = []
    seen = threading.Event()

    def on_event(event):
        events.append(event)
        if event.kind == "link_failed":
            seen.set()

    # The ring is a pty whose far end sends the request back unchanged (nobody captured it), then closes.
    master, slave = os.openpty()
    tty.setraw(master)
    ring = tether.elcano.RingClient(os.ttyname(slave), boot_wait=0, on_event=on_event)
    os.close(slave)

    def far_end():
        received = b""
        while not received.endswith(b"\n"):
            received += os.read(master, 64)
        os.write(master, received)

    loop = threading.Thread(target=far_end)
    loop.start()
    with pytest.raises(tether.ElcanoError):
        ring.request(tether.elcano.Message(type="drive", speed=5, angle=2), reply_type="sensor")
    loop.join()
    os.close(master)  # the pty goes away under the client
    assert seen.wait(20), [event.kind for event in events]
    ring.close()
    undeliverable = [event for event in events if event.kind == "undeliverable"]
    assert undeliverable and undeliverable[0].message.type == "drive" and undeliverable[0].error is None
    assert undeliverable[0].request_failed
    failed = [event for event in events if event.kind == "link_failed"]
    assert failed[0].message is None and failed[0].error
