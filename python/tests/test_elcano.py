"""tether.elcano.RingClient on a virtual ring of three elcano-node boards, opened from a rover config."""

import json

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
