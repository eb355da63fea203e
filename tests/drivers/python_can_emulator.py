"""python-can (Debian python3-can) drives hyq-can-emulator's devices on the virtual bus.

Run inside a private network namespace (in_netns.sh): starts the emulator on udp ports
PORT..PORT+3, then on the lf bus sends NMT "start all" and SYNCs as a CANopen master would, and
checks that the three actuator boards (nodes 1-3) and the IMU (node 16) answer every SYNC with
their TPDO1 (COB-ID 0x180 + node), and that they sent boot-up/heartbeats (0x700 + node).
Usage: python_can_emulator.py EMULATOR CONFIG PORT
"""
import subprocess
import sys
import time

import can

emulator, config, port = sys.argv[1], sys.argv[2], int(sys.argv[3])
proc = subprocess.Popen([emulator, "--config", config, "--seconds", "20",
                         "--interface", f"lf=udp::{port}", "--interface", f"rf=udp::{port + 1}",
                         "--interface", f"lh=udp::{port + 2}", "--interface", f"rh=udp::{port + 3}"],
                        stdout=subprocess.PIPE, text=True)
try:
    bus = can.Bus(interface="udp_multicast", channel="239.74.163.2", port=port,
                  receive_own_messages=False, fd=True)
    time.sleep(0.3)  # boot-up
    heartbeats = set()
    while (msg := bus.recv(timeout=0.05)) is not None:
        if 0x700 < msg.arbitration_id < 0x780:
            heartbeats.add(msg.arbitration_id - 0x700)
    bus.send(can.Message(arbitration_id=0x000, data=[0x01, 0x00], is_extended_id=False))
    time.sleep(0.05)
    answered = 0
    for cycle in range(20):
        bus.send(can.Message(arbitration_id=0x080, data=[cycle % 240 + 1], is_extended_id=False))
        seen = set()
        deadline = time.time() + 0.5
        while time.time() < deadline and seen != {1, 2, 3, 16}:
            msg = bus.recv(timeout=0.05)
            if msg is not None and 0x180 < msg.arbitration_id < 0x200:
                seen.add(msg.arbitration_id - 0x180)
        if seen == {1, 2, 3, 16}:
            answered += 1
        time.sleep(0.002)
    bus.shutdown()
finally:
    proc.terminate()
    out, _ = proc.communicate(timeout=10)
print(out)
print(f"heartbeat/boot-up from nodes {sorted(heartbeats)}; "
      f"{answered} of 20 SYNCs answered by nodes 1, 2, 3 and 16")
ok = answered == 20 and {1, 2, 3, 16} <= heartbeats
print("PASS" if ok else "FAIL")
sys.exit(0 if ok else 1)
