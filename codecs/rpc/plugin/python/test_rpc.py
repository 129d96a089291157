"""tether.rpc.Client against the example's image (examples/rpc/arm.proto, `rpc-example`) on virtual Unos:
the schema read at run time, replies as python3-protobuf messages, device errors, streams, asyncio."""

import asyncio
import os
import pathlib

import pytest
from google.protobuf import json_format, message

import tether

SCHEMA = str(pathlib.Path(__file__).resolve().parents[4] / "examples" / "rpc" / "arm.proto")


@pytest.fixture
def arm(report_board):
    with tether.VirtualUno("rpc-example", seed=5) as board:
        with tether.rpc.Client(board, SCHEMA) as client:
            yield client
        report_board(board)


def test_calls_return_the_schemas_messages(arm):
    assert arm.methods == ["MoveJoint", "Watch", "SetMode", "Describe"]
    assert arm.wait_ready() == arm.session().session_id
    assert arm.session().device_hash == arm.schema_hash
    reply = arm.call("MoveJoint", joint=2, angle_cdeg=-4500)
    assert isinstance(reply, message.Message) and isinstance(reply, arm.reply_type("MoveJoint"))
    assert reply.reached_cdeg == -4500
    # The request as a dict or as a message of the input type.
    assert arm.call("MoveJoint", {"joint": 1, "angle_cdeg": 1200}).reached_cdeg == 1200
    request = arm.request_type("MoveJoint")(joint=0, angle_cdeg=300)
    assert arm.call("MoveJoint", request).reached_cdeg == 300
    # Strings; a nested message in a request, as a dict.
    description = arm.call("Describe")
    assert description.name and description.joints >= 3
    assert description.min_cdeg < description.max_cdeg
    assert description.moves == 3
    assert json_format.MessageToDict(description)["moves"] == 3
    arm.call("SetMode", mode="MODE_ACTIVE", range={"min_cdeg": -100, "max_cdeg": 100})
    assert (arm.call("Describe").min_cdeg, arm.call("Describe").max_cdeg) == (-100, 100)
    with pytest.raises(tether.rpc.RpcDeviceError) as outside:
        arm.call("MoveJoint", joint=1, angle_cdeg=200)
    assert outside.value.code == 2
    counters = arm.counters()
    assert counters.replies == 7 and counters.device_errors == 1 and counters.messages_sent == 8
    assert counters.link.frames_ok >= 8


def test_enums_by_name_or_number_and_device_errors(arm):
    assert arm.call("SetMode", mode="MODE_HOLD").previous == 0
    with pytest.raises(tether.rpc.RpcDeviceError) as held:
        arm.call("MoveJoint", joint=1, angle_cdeg=0)
    assert held.value.code == 3 and held.value.text and not held.value.refused
    assert "MoveJoint" in held.value.message and isinstance(held.value, tether.RpcError)
    assert arm.call("SetMode", mode=1).previous == arm.request_type("SetMode")().DESCRIPTOR.fields_by_name[
        "mode"].enum_type.values_by_name["MODE_HOLD"].number
    with pytest.raises(tether.rpc.RpcDeviceError) as no_joint:
        arm.call("MoveJoint", joint=99, angle_cdeg=0)
    assert no_joint.value.code == 1
    assert arm.counters().device_errors == 2


def test_requests_rejected_before_sending(arm):
    with pytest.raises(tether.rpc.RpcRequestError, match="has no method Fly") as unknown:
        arm.call("Fly")
    assert isinstance(unknown.value, ValueError) and unknown.value.code == 4
    with pytest.raises(ValueError):  # python3-protobuf names the field
        arm.call("MoveJoint", joint=1, wrist=3)
    with pytest.raises((TypeError, ValueError)):
        arm.call("MoveJoint", joint="two")
    with pytest.raises(ValueError):
        arm.call("SetMode", mode="MODE_FLYING")
    with pytest.raises(TypeError, match="not both"):
        arm.call("MoveJoint", {"joint": 1}, angle_cdeg=3)
    with pytest.raises(TypeError, match="arm.JointRequest"):
        arm.call("MoveJoint", arm.request_type("SetMode")())
    with pytest.raises(tether.rpc.RpcRequestError, match="streams") as kind:
        arm.call("Watch")
    assert kind.value.code == 5
    with pytest.raises(tether.rpc.RpcRequestError, match="unary"):
        arm.stream("MoveJoint", period=0.1)
    assert arm.counters().messages_sent == 0


def test_streams_deliver_messages_at_the_period(arm):
    arm.call("MoveJoint", joint=0, angle_cdeg=4200)
    with arm.stream("Watch", period=0.02, count=5) as watch:
        states = list(watch)
        assert not watch.is_open, "closed after count messages"
    assert len(states) == 5
    assert all(isinstance(s, arm.reply_type("Watch")) for s in states)
    assert states[0].angles_cdeg[0] == 4200
    millis = [s.millis for s in states]
    assert millis == sorted(millis) and millis[-1] - millis[0] >= 4 * 20 - 5
    assert watch.seq >= 4 and watch.dropped == 0
    # A stream closed early stops; the client goes on.
    with arm.stream("Watch", period=0.05) as watch:
        next(watch)
    assert not watch.is_open
    assert arm.call("MoveJoint", joint=0, angle_cdeg=0).reached_cdeg == 0


def test_call_async():
    async def main(client):
        replies = await asyncio.gather(*(client.call_async("MoveJoint", joint=j, angle_cdeg=100 * j) for j in range(3)))
        return [r.reached_cdeg for r in replies]

    with tether.VirtualUno("rpc-example", seed=6) as board:
        with tether.rpc.Client(board, SCHEMA) as client:
            assert asyncio.run(main(client)) == [0, 100, 200]

            async def no_such_joint():
                return await client.call_async("MoveJoint", joint=99)

            with pytest.raises(tether.rpc.RpcDeviceError):
                asyncio.run(no_such_joint())


def test_a_device_of_another_schema_is_refused(tmp_path):
    other = tmp_path / "other.proto"
    other.write_text('syntax = "proto3";\npackage arm;\nmessage JointRequest { uint32 joint = 1; sint32 angle_cdeg = 2; }\n'
                     "message JointReply { int32 reached_cdeg = 1; }\n"
                     "service Arm { rpc MoveJoint(JointRequest) returns (JointReply); }\n")
    with tether.VirtualUno("rpc-example", seed=7) as board:
        with tether.rpc.Client(board, str(other), call_budget=1.0, queue_timeout=1.0) as client:
            with pytest.raises(tether.rpc.RpcError) as mismatch:
                client.wait_ready()
            assert mismatch.value.code == 3
            assert "other.proto" in mismatch.value.text and f"{client.schema_hash:016x}" in mismatch.value.text
            assert f"{client.session().device_hash:016x}" in mismatch.value.text
            with pytest.raises(tether.rpc.RpcError):
                client.call("MoveJoint", joint=1)


def test_bad_schemas_and_closed_clients(tmp_path):
    broken = tmp_path / "broken.proto"
    broken.write_text('syntax = "proto3";\nmessage A { int33 x = 1; }\n')
    with tether.VirtualUno("rpc-example", seed=8) as board:
        with pytest.raises(ValueError, match=r"broken.proto:2:\d+"):
            tether.rpc.Client(board, str(broken))
        with pytest.raises(ValueError):
            tether.rpc.Client(board, str(tmp_path / "missing.proto"))
        client = tether.rpc.Client(board, SCHEMA)
        client.close()
        with pytest.raises(tether.ClosedError):
            client.call("Describe")


def test_the_examples_python_script(monkeypatch, capsys):
    # examples/rpc/arm_client.py as a user runs it (`python3 arm_client.py --virtual rpc-example`), in this
    # process: its virtual board, the schema beside the script.
    import runpy
    import sys
    script = str(pathlib.Path(SCHEMA).with_name("arm_client.py"))
    monkeypatch.setattr(sys, "argv", [script, "--virtual", "rpc-example"])
    with pytest.raises(SystemExit) as exited:
        runpy.run_path(script, run_name="__main__")
    assert exited.value.code == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "MoveJoint(2, -4500): reached -4500"
    assert lines[1].startswith("MoveJoint(9, 0): device error 1: ")
    assert lines[2] == "SetMode(MODE_ACTIVE, -9000..9000): was MODE_IDLE"
    assert lines[3].startswith("Describe: ") and lines[3].endswith(" joints, -9000..9000, 1 moves")
    assert lines[4] == "Watch: 3 states, joint 2 at -4500"


def test_calls_go_on_after_the_board_is_plugged_in_again(unpluggable, link_events):
    # A board plugged in again boots afresh: the client's new session is with it (its move count starts over).
    board = unpluggable("rpc-example", seed=5)
    transport = tether.transports.serial(board.link, boot_wait=0)
    events = link_events(transport)
    with tether.rpc.Client(transport, SCHEMA) as arm:
        assert arm.call("MoveJoint", joint=1, angle_cdeg=1200).reached_cdeg == 1200
        assert arm.call("MoveJoint", joint=2, angle_cdeg=300).reached_cdeg == 300
        assert arm.call("Describe").moves == 2
        board.unplug()
        assert events.wait(1)["kind"] == "down"
        board.plug_in()
        assert events.wait(2)["kind"] == "up"
        assert arm.wait_ready() == arm.session().session_id
        assert arm.call("MoveJoint", joint=0, angle_cdeg=-700).reached_cdeg == -700
        assert arm.call("Describe").moves == 1
        assert transport.link_counters()["reconnects"] == 1
