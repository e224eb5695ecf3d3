#!/usr/bin/env python3
"""The latency of `armcal serve`: a KUKA (RSI) or ABB (EGM) controller's side, in Python.

Simulates a UR10e session (`armcal simulate`), identifies it (`armcal
identify --out`), starts `armcal serve --calibration CAL --rsi 127.0.0.1:0`
and plays the controller: a `<Rob Type="KUKA">` datagram per cycle (RIst,
RSol, AIPos, ASPos of a smooth motion in degrees, Delay, IPOC), each sent
when the previous answer came (unpaced; `--paced` waits for the 4 ms
tick), every answer's IPOC checked. With `--egm`, `armcal serve --egm` streams
the same motion as a joints file and the script plays an ABB controller: an
`EgmRobot` per cycle (header with its sequence number, feedback and planned
joints in degrees, motor and EGM states; protocol buffers written by hand
from `egm.proto`), every `EgmSensor` answer's sequence number checked (the
sensor's own, from 0) with its `planned.joints`. Then it stops sending: serve ends after
its timeout and prints its statistics, with the distribution of the time
from a datagram in to its answer out (p50, p99, max), which this script
prints with the controller's own round trip. Exits 1 (unless
`--report-only`) when an answer is missing or carries another IPOC, when
serve's p99 from datagram in to answer out is above a quarter of the 4 ms
cycle (the answer's own work is microseconds: a p99 that high is armcal's
slowness), when the controller saw two answers in a row later than the
cycle (a controller stops on a run of late answers), or when more than one
answer in 10^3 was late. A machine that is not real-time (CI's shared
virtual machines) preempts a process now and then for some milliseconds:
such isolated late answers (0 to 2 in 10^4 on CI's machines) are printed,
not failed, as a KUKA controller tolerates a configured number of them; a
deployment removes them with a real-time priority (docs/controllers.md).

Run from the repository root after `cargo build --release -p armcal`:

    python3 scripts/serve-latency.py [--armcal target/release/armcal] [--cycles 100000] [--paced] [--egm] [--report-only]
"""

import argparse
import math
import os
import re
import socket
import struct
import subprocess
import sys
import tempfile
import time

# The RSI cycle (serve's --cycle-ms default) and the isolated late answers
# tolerated: at most one in LATE_PER.
CYCLE_US = 4000
LATE_PER = 1_000


def rob(q, ipoc):
    axes = "".join(f' A{m + 1}="{v:.4f}"' for m, v in enumerate(q))
    pose = 'X="445.0000" Y="0.0000" Z="890.0000" A="0.0000" B="90.0000" C="0.0000"'
    return (
        f'<Rob Type="KUKA">\r\n<RIst {pose} />\r\n<RSol {pose} />\r\n<AIPos{axes} />\r\n'
        f'<ASPos{axes} />\r\n<Delay D="0" />\r\n<IPOC>{ipoc}</IPOC>\r\n</Rob>\r\n'
    ).encode()


def varint(v):
    out = bytearray()
    while True:
        byte, v = v & 0x7F, v >> 7
        if v == 0:
            out.append(byte)
            return bytes(out)
        out.append(byte | 0x80)


def field(tag, wire, body):
    """A protocol-buffers field: its key (tag, wire type) and body."""
    if wire == 2:
        body = varint(len(body)) + body
    return varint(tag << 3 | wire) + body


def egm_robot(seqno, q):
    """An `EgmRobot`: header (seqno, tm, mtype 2 = data), feedback and
    planned joints (degrees, unpacked doubles), motor on, EGM running, RAPID
    running, the test signal's state: as an ABB controller sends it."""
    header = field(1, 0, varint(seqno)) + field(2, 0, varint(4 * seqno)) + field(3, 0, varint(2))
    joints = b"".join(field(1, 1, struct.pack("<d", v)) for v in q)
    position = field(1, 2, joints)
    return (field(1, 2, header) + field(2, 2, position) + field(3, 2, position)
            + field(4, 2, b"\x08\x01") + field(5, 2, b"\x08\x03") + field(6, 0, varint(1))
            + field(8, 2, b"\x08\x02"))


def fields(data):
    """The (tag, value) fields of a message: an int, 8 bytes or the bytes."""
    at, out = 0, []
    while at < len(data):
        key, at = read_varint(data, at)
        tag, wire = key >> 3, key & 7
        if wire == 0:
            value, at = read_varint(data, at)
        elif wire == 1:
            value, at = data[at:at + 8], at + 8
        elif wire == 2:
            n, at = read_varint(data, at)
            value, at = data[at:at + n], at + n
        else:
            raise ValueError(f"wire type {wire}")
        out.append((tag, value))
    return out


def read_varint(data, at):
    v, shift = 0, 0
    while True:
        b = data[at]
        at += 1
        v |= (b & 0x7F) << shift
        shift += 7
        if b & 0x80 == 0:
            return v, at


def egm_sensor(data):
    """An `EgmSensor`'s header sequence number and its planned joints."""
    seqno, joints = None, []
    for tag, value in fields(data):
        if tag == 1:
            seqno = dict(fields(value)).get(1)
        elif tag == 2:
            for t, v in fields(value):
                if t == 1:
                    for _, x in fields(v):
                        joints.extend(struct.unpack(f"<{len(x) // 8}d", x))
    return seqno, joints


def quantile(sorted_values, p):
    return sorted_values[max(0, math.ceil(p * len(sorted_values)) - 1)]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = os.path.join(os.environ.get("CARGO_TARGET_DIR", "target"), "release", "armcal")
    parser.add_argument("--armcal", default=default)
    parser.add_argument("--cycles", type=int, default=100_000)
    parser.add_argument("--paced", action="store_true")
    parser.add_argument("--egm", action="store_true")
    parser.add_argument("--report-only", action="store_true")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        data, cal = os.path.join(tmp, "d.csv"), os.path.join(tmp, "cal.bin")
        subprocess.run([args.armcal, "simulate", "--model", "ur10e", "--out", data], check=True,
                       capture_output=True)
        subprocess.run([args.armcal, "identify", "--model", "ur10e", "--data", data, "--out", cal,
                        "--quiet"], check=True, capture_output=True)
        q0 = [91.0, 33.1, -96.0, 20.1, 102.2, 127.9]
        motion = lambda t: [q0[j] + 15.0 * math.sin(2 * math.pi * t / 5000 + j) for j in range(6)]
        if args.egm:
            joints = os.path.join(tmp, "j.csv")
            with open(joints, "w") as f:
                f.write("q1,q2,q3,q4,q5,q6\n")
                for t in range(args.cycles):
                    f.write(",".join(f"{math.radians(v):.12f}" for v in motion(t)) + "\n")
            protocol = ["--egm", "127.0.0.1:0", "--joints", joints]
        else:
            protocol = ["--rsi", "127.0.0.1:0"]
        server = subprocess.Popen(
            [args.armcal, "serve", "--calibration", cal, *protocol, "--timeout-ms", "300"],
            stderr=subprocess.PIPE, text=True)
        first = server.stderr.readline()
        address = re.search(r" on (\S+):(\d+) ", first)
        if not address:
            sys.exit(f"serve did not start: {first}")
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.connect((address.group(1), int(address.group(2))))
        sock.settimeout(1.0)
        rtts, failures = [], 0
        # Answers the controller saw later than the cycle, in a row.
        in_a_row, longest_run = 0, 0
        next_tick = time.perf_counter()
        for t in range(args.cycles):
            q = motion(t)
            ipoc = 4208163 + 4 * t
            if args.paced:
                next_tick += 0.004
                time.sleep(max(0.0, next_tick - time.perf_counter()))
            sent = time.perf_counter()
            sock.send(egm_robot(t, q) if args.egm else rob(q, ipoc))
            try:
                answer = sock.recv(2048)
            except socket.timeout:
                failures += 1
                continue
            rtts.append(time.perf_counter() - sent)
            late = rtts[-1] * 1e6 > CYCLE_US
            in_a_row = in_a_row + 1 if late else 0
            longest_run = max(longest_run, in_a_row)
            if args.egm:
                seqno, planned = egm_sensor(answer)
                if seqno != t or len(planned) != 6:
                    failures += 1
            elif f"<IPOC>{ipoc}</IPOC>".encode() not in answer:
                failures += 1
        sock.close()
        stats = server.stderr.read()
        server.wait()
    print(stats, end="")
    rtts.sort()
    us = lambda s: f"{s * 1e6:.0f} us"
    print(f"controller's round trip ({'EGM' if args.egm else 'RSI'}, "
          f"{'paced at 4 ms' if args.paced else 'unpaced'}, "
          f"{len(rtts)} answers): p50 {us(quantile(rtts, 0.5))}, p99 {us(quantile(rtts, 0.99))}, "
          f"max {us(rtts[-1])}; {failures} missing or wrong; "
          f"at most {longest_run} in a row later than the cycle")
    late = re.search(r"  late (\d+)", stats)
    p99 = re.search(r"p99 (\d+) us", stats)
    reasons = []
    if failures > 0 or server.returncode != 0:
        reasons.append(f"{failures} answers missing or wrong, serve's exit status {server.returncode}")
    if not late or not p99:
        reasons.append("serve printed no late count or no p99")
    else:
        if int(p99.group(1)) > CYCLE_US // 4:
            reasons.append(f"p99 {p99.group(1)} us, above a quarter of the {CYCLE_US} us cycle")
        if int(late.group(1)) * LATE_PER > args.cycles:
            reasons.append(f"{late.group(1)} late answers, more than 1 in {LATE_PER}")
    if longest_run > 1:
        reasons.append(f"{longest_run} answers in a row later than the cycle")
    if reasons and not args.report_only:
        sys.exit("serve-latency: " + "; ".join(reasons))


if __name__ == "__main__":
    main()
