#!/usr/bin/env python3
"""Times the boards' answers in a bus trace of a HIL run (scripts/hil.sh --bus-trace).

usage: bus_trace_report.py [--episodes N] [--context K] [--json FILE] DIR

Reads DIR/bus_<name>.log (candump format with kernel receive timestamps, one per bus, written by
hyq-candump) and prints, per bus and over all buses:
  - SYNC intervals (the master's cycle as the wire saw it): p50 / p99 / max;
  - answer latency: from a SYNC to each board's TPDO1 echoing its counter, p50 / p99 / p99.9 / max;
  - late answers: TPDOs that arrived after a newer SYNC on their bus (the master discards them);
  - unanswered cycles: SYNCs after which some board had not answered when the next SYNC went out
    (the master had read by then: a held input, or a fault after timing.max_held_cycles in a row);
then the longest runs of unanswered cycles ("episodes") and, for the longest, every SYNC and
answer on all buses around it, in time order. The first line is a one-line summary; --json
writes the per-bus numbers to FILE as well.

Exit status: 0 ok, 2 bad arguments or no readable trace in DIR.
"""
import argparse
import glob
import json
import os
import re
import sys

LINE = re.compile(r"\((\d+)\.(\d+)\)\s+(\S+)\s+([0-9A-Fa-f]+)#(#[0-9A-Fa-f])?([0-9A-Fa-f]*)")
SYNC_ID = 0x080
ACTUATOR_TPDO_LEN, IMU_TPDO_LEN = 16, 32  # hal/protocol.h (kActuatorTpdoLen, kImuTpdoLen): where the SYNC counter is echoed


def tpdo_counter(data):
    if len(data) == ACTUATOR_TPDO_LEN:
        return data[14]
    if len(data) == IMU_TPDO_LEN:
        return data[26]
    return None


def read_bus(path):
    """Returns [(t_ns, kind, node, counter)], kind 'S' (SYNC) or 'T' (TPDO1)."""
    events = []
    with open(path) as f:
        for n, line in enumerate(f, 1):
            m = LINE.match(line)
            if not m:
                continue
            t = int(m.group(1)) * 1_000_000_000 + int(m.group(2).ljust(9, "0")[:9])
            cid = int(m.group(4), 16)
            data = bytes.fromhex(m.group(6))
            if cid == SYNC_ID and data:
                events.append((t, "S", 0, data[0]))
            elif 0x180 < cid < 0x200:
                c = tpdo_counter(data)
                if c is not None:
                    events.append((t, "T", cid - 0x180, c))
    events.sort()
    return events


def pct(v, q):
    if not v:
        return float("nan")
    v = sorted(v)
    return v[min(len(v) - 1, int(q * len(v)))]


def analyse(events):
    syncs = [(t, c) for t, k, _, c in events if k == "S"]
    nodes = sorted({n for _, k, n, _ in events if k == "T"})
    gaps = [(syncs[i + 1][0] - syncs[i][0]) / 1e3 for i in range(len(syncs) - 1)]
    latency, late = [], 0
    # per SYNC (by index): the boards that answered it before the next SYNC
    answered = [set() for _ in syncs]
    si = -1
    for t, k, n, c in events:
        if k == "S":
            si += 1
            continue
        if si < 0:
            continue
        if c != syncs[si][1]:
            late += 1
            continue
        answered[si].add(n)
        latency.append((t - syncs[si][0]) / 1e3)
    # a SYNC counts once the boards answer at all (the ones before NMT start get no answer)
    first = next((i for i, a in enumerate(answered) if a), len(syncs))
    unanswered = [i for i in range(first, len(syncs) - 1) if answered[i] != set(nodes)]
    missing_by_node = {n: sum(1 for i in unanswered if n not in answered[i]) for n in nodes}
    return dict(syncs=syncs, nodes=nodes, gaps=gaps, latency=latency, late=late,
                answered=answered, unanswered=unanswered, missing_by_node=missing_by_node)


def episodes(unanswered):
    """Runs of consecutive SYNC indices: [(start_index, length)]."""
    runs = []
    for i in unanswered:
        if runs and runs[-1][0] + runs[-1][1] == i:
            runs[-1][1] += 1
        else:
            runs.append([i, 1])
    return [tuple(r) for r in runs]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dir")
    ap.add_argument("--episodes", type=int, default=5, help="longest episodes listed (default 5)")
    ap.add_argument("--context", type=int, default=4,
                    help="SYNCs shown before and after the longest episode (default 4)")
    ap.add_argument("--json", metavar="FILE", help="also write the per-bus numbers as JSON")
    a = ap.parse_args()
    paths = sorted(glob.glob(os.path.join(a.dir, "bus_*.log")))
    if not paths:
        print(f"bus_trace_report.py: no bus_<name>.log in {a.dir} (record with scripts/hil.sh --bus-trace)",
              file=sys.stderr)
        return 2
    buses = {}
    for p in paths:
        name = os.path.basename(p)[4:-4]
        ev = read_bus(p)
        if ev:
            buses[name] = (ev, analyse(ev))
    if not buses:
        print(f"bus_trace_report.py: the traces in {a.dir} hold no SYNC or TPDO", file=sys.stderr)
        return 2
    t0 = min(ev[0][0] for ev, _ in buses.values())
    all_lat = [x for _, r in buses.values() for x in r["latency"]]
    all_late = sum(r["late"] for _, r in buses.values())
    all_un = sum(len(r["unanswered"]) for _, r in buses.values())
    longest = max((ln for _, r in buses.values() for _, ln in episodes(r["unanswered"])), default=0)
    print(f"bus trace: {len(buses)} buses, answer latency p50 {pct(all_lat, .5):.0f} us, "
          f"p99 {pct(all_lat, .99):.0f} us, max {max(all_lat, default=float('nan')):.0f} us; "
          f"late answers {all_late}; cycles with an answer missing {all_un}, longest run {longest}")
    print()
    print("| bus | SYNCs | SYNC interval p50 / p99 / max (us) | answer latency p50 / p99 / p99.9 / max (us) | late answers | cycles with an answer missing | longest run |")
    print("|---|---|---|---|---|---|---|")
    for name, (_, r) in buses.items():
        g, lat = r["gaps"], r["latency"]
        eps = episodes(r["unanswered"])
        print(f"| {name} | {len(r['syncs'])} | {pct(g, .5):.0f} / {pct(g, .99):.0f} / {max(g, default=float('nan')):.0f} | "
              f"{pct(lat, .5):.0f} / {pct(lat, .99):.0f} / {pct(lat, .999):.0f} / {max(lat, default=float('nan')):.0f} | "
              f"{r['late']} | {len(r['unanswered'])} | {max((ln for _, ln in eps), default=0)} |")
    if a.json:
        doc = {}
        for name, (_, r) in buses.items():
            lat = r["latency"]
            doc[name] = dict(syncs=len(r["syncs"]), answers=len(lat), late_answers=r["late"],
                             cycles_missing=len(r["unanswered"]),
                             missing_by_node={str(n): c for n, c in r["missing_by_node"].items()},
                             longest_run=max((ln for _, ln in episodes(r["unanswered"])), default=0),
                             latency_p50_us=pct(lat, .5), latency_p99_us=pct(lat, .99),
                             latency_max_us=max(lat, default=None))
        with open(a.json, "w") as f:
            json.dump({"buses": doc}, f, indent=1)
    print()
    print("An answer still missing when the next SYNC went out was missing when the master read (it reads")
    print("just before it sends the SYNC); times are seconds since the first frame of the trace.")
    allep = sorted(((ln, name, i) for name, (_, r) in buses.items() for i, ln in episodes(r["unanswered"])),
                   reverse=True)[: a.episodes]
    if not allep:
        return 0
    print()
    print("longest runs of cycles with an answer missing:")
    for ln, name, i in allep:
        r = buses[name][1]
        print(f"  bus {name}: {ln} in a row from SYNC {r['syncs'][i][1]} at {(r['syncs'][i][0] - t0) / 1e9:.4f} s")
    ln, name, i = allep[0]
    r = buses[name][1]
    lo = r["syncs"][max(0, i - a.context)][0]
    hi = r["syncs"][min(len(r["syncs"]) - 1, i + ln + a.context)][0]
    print()
    print(f"around the longest (bus {name}), every bus (ms since the first frame):")
    merged = sorted((t, b, k, n, c) for b, (ev, _) in buses.items() for t, k, n, c in ev if lo <= t <= hi)
    for t, b, k, n, c in merged:
        what = f"SYNC {c}" if k == "S" else f"  node {n} answers {c}"
        print(f"  {(t - t0) / 1e6:11.3f}  {b:3}  {what}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
