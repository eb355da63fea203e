#!/usr/bin/python3
"""Records HyQ's four virtual CAN buses with python-can into candump logs, one file per bus.

Usage: python_can_logger.py OUTPREFIX [--group G] [--port-base P] [--buses lf,rf,lh,rh]

Bus i (lf, rf, lh, rh) is python-can's `udp_multicast` interface on group G (default 239.74.163.2,
drivers/udp_multicast_channel.h) and port P + i (default 43101: hyq-sim's and hyq-servod's
udp::43101..43104). Every frame heard is written by python-can's own candump writer
(can.io.CanutilsLogWriter, `(time) IFACE ID#DATA`, FD frames `ID##FDATA`) to OUTPREFIX_<bus>.log
with the bus name as the interface. Prints "ready" once every bus is open. SIGTERM / SIGINT stop it
cleanly: the listeners are stopped, the files flushed and closed, and a summary (frames per bus)
is printed. Run with /usr/bin/python3 (Debian's python3-can).
"""
import argparse
import signal
import socket
import sys
import threading

import can

ap = argparse.ArgumentParser()
ap.add_argument("outprefix")
ap.add_argument("--group", default="239.74.163.2")
ap.add_argument("--port-base", type=int, default=43101)
ap.add_argument("--buses", default="lf,rf,lh,rh")
args = ap.parse_args()

stop = threading.Event()
signal.signal(signal.SIGTERM, lambda *_: stop.set())
signal.signal(signal.SIGINT, lambda *_: stop.set())


class Counting(can.Listener):
    def __init__(self, writer):
        self.writer, self.n = writer, 0

    def on_message_received(self, msg):
        self.writer.on_message_received(msg)
        self.n += 1

    def stop(self):
        self.writer.stop()  # flushes and closes the file


names = args.buses.split(",")
buses, notifiers, listeners = [], [], []
for i, name in enumerate(names):
    bus = can.Bus(interface="udp_multicast", channel=args.group, port=args.port_base + i,
                  hop_limit=0, fd=True, receive_own_messages=False)
    # a deep receive queue: at lock-step speed a bus carries several 10^4 frames/s
    try:
        sock = bus._multicast._socket  # python-can 4.1's GeneralPurposeUdpMulticastBus
        sock.setsockopt(socket.SOL_SOCKET, 33, 16 << 20)  # SO_RCVBUFFORCE (root)
    except Exception:
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 16 << 20)
        except Exception:
            pass
    listener = Counting(can.io.CanutilsLogWriter(f"{args.outprefix}_{name}.log", channel=name))
    buses.append(bus)
    listeners.append(listener)
    notifiers.append(can.Notifier(bus, [listener], timeout=0.1))
print("ready", flush=True)

stop.wait()
for n in notifiers:
    n.stop()  # joins the reader thread, then calls listener.stop(): files flushed and closed
for b in buses:
    b.shutdown()
print("python_can_logger: " + ", ".join(f"{name} {l.n} frames -> {args.outprefix}_{name}.log"
                                        for name, l in zip(names, listeners)), flush=True)
