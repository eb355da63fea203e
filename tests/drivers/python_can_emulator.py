"""python-can (Debian python3-can) drives hyq-can-emulator's devices on the virtual bus.

Run inside a private network namespace (in_netns.sh): starts the emulator on udp ports
PORT..PORT+3, then on the lf bus sends NMT "start all" and SYNCs as a CANopen master would, and
checks that the three actuator boards (nodes 1-3) and the IMU (node 16) answer every SYNC with
their TPDO1 (COB-ID 0x180 + node), and that they sent boot-up/heartbeats (0x700 + node).
Usage: python_can_emulator.py EMULATOR CONFIG PORT
"""
import os
import subprocess
import sys
import tempfile
import time

import can

emulator, config, port = sys.argv[1], sys.argv[2], int(sys.argv[3])

# The boards drop to PRE-OPERATIONAL when SYNCs stop for timing.device_setpoint_timeout_s (8 ms on
# the robot). A Python master beside a busy CPU can pause longer than that between SYNCs, and the
# timer has its own tests (emulator_test, hil_e2e.kill9_boards_drop_torque): here it gets 5 s, so
# that what is tested is the protocol spoken by python-can.
with open(config) as f:
    text = f.read()
if "\ntiming:\n" not in text or "device_setpoint_timeout_s" in text:
    sys.exit(f"{config}: expected a 'timing:' section without device_setpoint_timeout_s")
tmp = tempfile.NamedTemporaryFile("w", suffix=".yaml", prefix="python_can_emulator_", delete=False)
tmp.write(text.replace("\ntiming:\n", "\ntiming:\n  device_setpoint_timeout_s: 5.0\n", 1))
tmp.close()
config = tmp.name
proc = subprocess.Popen([emulator, "--config", config, "--seconds", "60",
                         "--interface", f"lf=udp::{port}", "--interface", f"rf=udp::{port + 1}",
                         "--interface", f"lh=udp::{port + 2}", "--interface", f"rh=udp::{port + 3}"],
                        stdout=subprocess.PIPE, text=True)
try:
    bus = can.Bus(interface="udp_multicast", channel="239.74.163.2", port=port,
                  receive_own_messages=False, fd=True)
    # Every wait below ends on an event, with a bound far above an idle machine's time, so that a
    # loaded machine is slower but not wrong: first every device's boot-up or heartbeat.
    nodes = {1, 2, 3, 16}
    heartbeats = set()
    deadline = time.monotonic() + 15.0
    while time.monotonic() < deadline and not nodes <= heartbeats:
        msg = bus.recv(timeout=0.05)
        if msg is not None and 0x700 < msg.arbitration_id < 0x780:
            heartbeats.add(msg.arbitration_id - 0x700)
    bus.send(can.Message(arbitration_id=0x000, data=[0x01, 0x00], is_extended_id=False))

    def sync_answered(counter, wait_s):
        """Sends one SYNC; True when nodes 1, 2, 3 and 16 all answer it within wait_s."""
        bus.send(can.Message(arbitration_id=0x080, data=[counter % 240 + 1], is_extended_id=False))
        seen = set()
        until = time.monotonic() + wait_s
        while time.monotonic() < until and seen != nodes:
            msg = bus.recv(timeout=0.05)
            if msg is not None and 0x180 < msg.arbitration_id < 0x200:
                seen.add(msg.arbitration_id - 0x180)
        return seen == nodes

    # NMT "start" takes effect when the devices read it: SYNC until the first full answer
    started = False
    deadline = time.monotonic() + 10.0
    cycle = 0
    while time.monotonic() < deadline and not started:
        started = sync_answered(cycle, 0.2)
        cycle += 1
    answered = 0
    if started:
        for _ in range(20):
            answered += sync_answered(cycle, 2.0)
            cycle += 1
    bus.shutdown()
finally:
    proc.terminate()
    out, _ = proc.communicate(timeout=10)
    os.unlink(config)
print(out)
print(f"heartbeat/boot-up from nodes {sorted(heartbeats)}; "
      f"{answered} of 20 SYNCs answered by nodes 1, 2, 3 and 16")
ok = answered == 20 and {1, 2, 3, 16} <= heartbeats
print("PASS" if ok else "FAIL")
sys.exit(0 if ok else 1)
