"""Recording a link from Python: a client's ``record=`` (a file name, or a dict like a configuration's
``record``), a rover configuration's ``"record"``; the capture read back with tshark (interface name,
direction, comments) and by hand (pcapng blocks); an existing file is FileExistsError unless ``overwrite``."""

import json
import shutil
import struct
import subprocess

import pytest

import tether


def pcapng_blocks(path):
    """(type, body) of every block of a little-endian pcapng file."""
    data = open(path, "rb").read()
    blocks = []
    at = 0
    while at < len(data):
        kind, length = struct.unpack_from("<II", data, at)
        blocks.append((kind, data[at + 8:at + length - 4]))
        at += length
    return blocks


def packets(path):
    """(direction, bytes, comment) of every Enhanced Packet Block."""
    result = []
    for kind, body in pcapng_blocks(path):
        if kind != 6:
            continue
        _, _, _, captured, _ = struct.unpack_from("<IIIII", body, 0)
        data = body[20:20 + captured]
        at = 20 + (captured + 3) // 4 * 4
        direction, comment = 0, ""
        while at + 4 <= len(body):
            code, size = struct.unpack_from("<HH", body, at)
            value = body[at + 4:at + 4 + size]
            at += 4 + (size + 3) // 4 * 4
            if code == 0:
                break
            if code == 1:
                comment = value.decode()
            if code == 2:
                direction = struct.unpack("<I", value)[0] & 3
        result.append((direction, data, comment))
    return result


def test_a_client_records_its_link(tmp_path):
    capture = tmp_path / "arm.pcapng"
    with tether.VirtualUno("romi-test") as board:
        client = tether.romi.Client(board.port, boot_wait=0, boot="none", record=capture)
        assert client.call("e") == [0, 1, 2]
        client.close()
    frames = [(direction, data) for direction, data, comment in packets(capture) if not comment]
    assert frames[0][0] == 2 and frames[0][1].startswith(b"#e:") and frames[0][1].endswith(b"\r\n")
    assert frames[-1][0] == 1 and frames[-1][1].startswith(b"#e[0,1,2]:")
    if shutil.which("tshark"):
        out = subprocess.run(["tshark", "-r", str(capture), "-T", "fields", "-e", "frame.interface_name",
                              "-e", "frame.interface_description"], capture_output=True, text=True, check=True).stdout
        name, description = out.splitlines()[0].split("\t")
        assert name == board.port
        assert description == "tether codec=romi baud=115200 transport=serial"


def test_an_existing_file_is_not_overwritten_unless_asked(tmp_path):
    capture = tmp_path / "kept.pcapng"
    capture.write_bytes(b"precious")
    with tether.VirtualUno("romi-test") as board:
        with pytest.raises(FileExistsError, match="kept.pcapng: File exists"):
            tether.romi.Client(board.port, boot_wait=0, boot="none", record=str(capture))
        assert capture.read_bytes() == b"precious"
        client = tether.romi.Client(board.port, boot_wait=0, boot="none",
                                    record={"file": str(capture), "overwrite": True})
        assert client.call("e") == [0, 1, 2]
        client.close()
    assert any(not comment for _, _, comment in packets(capture))


def test_bad_record_values_are_errors_before_anything_opens(tmp_path):
    with tether.VirtualUno("romi-test") as board:
        with pytest.raises(TypeError, match="record"):
            tether.romi.Client(board.port, boot_wait=0, boot="none", record=5)
        with pytest.raises(ValueError, match="unknown key 'size'"):
            tether.romi.Client(board.port, boot_wait=0, boot="none", record={"file": str(tmp_path / "x"), "size": 1})
        with pytest.raises(OSError, match="No such file or directory"):
            tether.romi.Client(board.port, boot_wait=0, boot="none", record="/nonexistent/x.pcapng")


def test_a_rover_configuration_records_every_device_into_one_file(tmp_path):
    capture = tmp_path / "rover.pcapng"
    with tether.VirtualUno("romi-test") as board:
        config = tmp_path / "rover.json"
        config.write_text(json.dumps({
            "record": "rover.pcapng",
            "devices": [{"name": "arm", "codec": "romi",
                         "transport": {"serial": {"path": board.port, "reconnect": False, "boot": "none"}}}]}))
        rover = tether.open_rover(str(config))
        try:
            assert rover.romi("arm").call("e") == [0, 1, 2]
        finally:
            rover.close()
    blocks = pcapng_blocks(capture)
    assert [kind for kind, _ in blocks][:2] == [0x0A0D0D0A, 1]
    assert b"arm" in blocks[1][1]
    assert any(direction == 1 and not comment for direction, _, comment in packets(capture))


def interface_descriptions(path):
    """if_description (option 3) of every Interface Description Block."""
    descriptions = []
    for kind, body in pcapng_blocks(path):
        if kind != 1:
            continue
        at = 8
        while at + 4 <= len(body):
            code, size = struct.unpack_from("<HH", body, at)
            if code == 0:
                break
            if code == 3:
                descriptions.append(body[at + 4:at + 4 + size].decode())
            at += 4 + (size + 3) // 4 * 4
    return descriptions


def test_an_elcano_ring_client_records_its_link_with_the_rings_generation(tmp_path):
    capture = tmp_path / "ring.pcapng"
    with tether.VirtualUno("elcano-node") as board:
        client = tether.elcano.RingClient(board.port, generation="B", boot="none", record=capture)
        # The board, configured for nothing, forwards the message: it comes back round the ring.
        with pytest.raises(tether.elcano.ElcanoError, match="came back round the ring"):
            client.request(tether.elcano.Message(type="drive", speed=50, angle=25), reply_type="sensor")
        client.close()
    assert interface_descriptions(capture) == ["tether codec=elcano baud=115200 transport=serial generation=B"]
    frames = [(direction, data) for direction, data, comment in packets(capture) if not comment]
    assert (2, frames[0][1]) == frames[0] and frames[0][1].startswith(b"D{s 50}{a 25}")
    # The board re-encodes what it forwards.
    assert any(direction == 1 and data.startswith(b"D{") and data.endswith(b"\n") for direction, data in frames[1:])
