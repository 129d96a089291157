#!/usr/bin/env python3
"""The arm of arm.proto from Python: the schema is read at run time (no generated files), replies are
python3-protobuf messages, device errors are exceptions with the device's code and text.

    python3 arm_client.py /dev/ttyACM0          an Uno running the example's sketch
    python3 arm_client.py --virtual rpc-example  the example's image on a virtual Uno
"""
import pathlib
import sys

import tether

SCHEMA = pathlib.Path(__file__).resolve().parent / "arm.proto"


def run(arm):
    arm.wait_ready()  # the device answered with arm.proto's hash
    print("MoveJoint(2, -4500): reached", arm.call("MoveJoint", joint=2, angle_cdeg=-4500).reached_cdeg)
    try:
        arm.call("MoveJoint", joint=9, angle_cdeg=0)
    except tether.rpc.RpcDeviceError as e:
        print(f"MoveJoint(9, 0): device error {e.code}: {e.text}")
    previous = arm.call("SetMode", mode="MODE_ACTIVE", range={"min_cdeg": -9000, "max_cdeg": 9000}).previous
    print("SetMode(MODE_ACTIVE, -9000..9000): was", arm.request_type("SetMode")().DESCRIPTOR.fields_by_name[
        "mode"].enum_type.values_by_number[previous].name)
    d = arm.call("Describe")
    print(f"Describe: {d.name}, {d.joints} joints, {d.min_cdeg}..{d.max_cdeg}, {d.moves} moves")
    states = list(arm.stream("Watch", period=0.05, count=3))
    print(f"Watch: {len(states)} states, joint 2 at {states[-1].angles_cdeg[2]}")


def main(argv):
    if len(argv) == 3 and argv[1] == "--virtual":
        with tether.VirtualUno(argv[2]) as board, tether.rpc.Client(board, str(SCHEMA)) as arm:
            run(arm)
    elif len(argv) == 2:
        with tether.rpc.Client(argv[1], str(SCHEMA), boot_wait=2.0) as arm:
            run(arm)
    else:
        print(__doc__, file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
