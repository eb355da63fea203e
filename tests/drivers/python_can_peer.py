#!/usr/bin/python3
"""Echo peer for python_can_interop_test.cc, using python-can's own udp_multicast interface.

Usage: python_can_peer.py GROUP PORT COUNT

Prints "ready" once its bus is open, then for each of COUNT received frames prints
"rx <description>" and sends back a frame with arbitration_id ^ 1 and the data reversed (same
flags), so the C++ side checks both python-can's decoding of our datagrams and our decoding of
python-can's. Exits 0 after COUNT frames, 2 when none arrives for 10 s.

python-can's udp_multicast bus hears its own datagrams (multicast loopback on; its
receive_own_messages=True is not implemented, and False does not filter): its own replies are
recognised and skipped, not echoed. (Under load the C++ side's frames arrive spread out, and a
reply heard back between them started an echo loop: the test's one known flake.)
"""
import collections
import sys

import can


def describe(m: can.Message) -> str:
    return (f"{m.arbitration_id:x} ext={int(m.is_extended_id)} rtr={int(m.is_remote_frame)} "
            f"err={int(m.is_error_frame)} fd={int(m.is_fd)} brs={int(m.bitrate_switch)} "
            f"esi={int(m.error_state_indicator)} dlc={m.dlc} data={m.data.hex()}")


def main() -> int:
    group, port, count = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    bus = can.Bus(interface="udp_multicast", channel=group, port=port, hop_limit=0, fd=True)
    print("ready", flush=True)
    own = collections.Counter()  # descriptions of the replies sent and not yet heard back
    try:
        received = 0
        while received < count:
            m = bus.recv(timeout=10)
            if m is None:
                print("timeout", flush=True)
                return 2
            if own[describe(m)] > 0:
                own[describe(m)] -= 1
                continue
            received += 1
            print("rx " + describe(m), flush=True)
            reply = can.Message(
                arbitration_id=m.arbitration_id ^ 1, is_extended_id=m.is_extended_id,
                is_remote_frame=m.is_remote_frame, is_error_frame=m.is_error_frame,
                is_fd=m.is_fd, bitrate_switch=m.bitrate_switch,
                error_state_indicator=m.error_state_indicator, dlc=m.dlc,
                data=None if m.is_remote_frame else bytes(reversed(m.data)), check=True)
            own[describe(reply)] += 1
            bus.send(reply)
    finally:
        bus.shutdown()
    print("done", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
