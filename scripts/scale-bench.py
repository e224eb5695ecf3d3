#!/usr/bin/env python3
"""The scale benchmark: armcal on a laser tracker's long session.

A tracker streams 1,000 points a second: a 15-minute session is 10⁶
positions. This simulates one (a PUMA 560, `armcal simulate --poses 1000000`),
then measures the wall time and the peak memory (the child's maximum resident
set size) of

- `armcal simulate` of the 10⁶ positions, written as they are drawn:
  budget 50 MB (its memory does not grow with the poses);
- `armcal identify` on all 10⁶ positions: budget 2 s and 300 MB;
- `armcal diagnose` on all 10⁶: budget 10 s and 1 GB (the model chosen on
  every 10th position, the calibration fitted to all: docs/diagnosis.md);
- `armcal diagnose` on the first 10⁵ (the whole diagnosis): budget 5 s;
- `armcal check` on all 10⁶ (reported, no budget), and on 3·10⁶ rows of
  nine short numbers, the most a measurement file holds: budget 1 GB (the
  rows, not the bytes, bound the memory);
- `armcal plan`: 30 poses of a UR10e from 10⁴ candidates, budget 1 s; and
  from 10⁵, the most candidates a plan takes: budget 300 MB;

each the best of three runs. Prints a table and exits 1 when a budget is
exceeded (`--report-only`: exits 0, as CI runs it, whose machines vary).
Run from the repository root after `cargo build --release -p armcal`:

    python3 scripts/scale-bench.py [--armcal target/release/armcal] [--runs N] [--report-only]
"""

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time

BUDGETS = {
    # name: (seconds, MB)
    "simulate 10^6": (None, 50.0),
    "identify 10^6": (2.0, 300.0),
    "diagnose 10^6": (10.0, 1000.0),
    "diagnose 10^5": (5.0, None),
    "check 10^6": (None, None),
    "check 3*10^6 short rows": (None, 1000.0),
    "plan 30 of 10^4": (1.0, None),
    "plan 30 of 10^5": (None, 300.0),
}


def run(cmd):
    """Wall seconds and peak resident MB of one run of `cmd` (in a fresh
    process, so that RUSAGE_CHILDREN is this run's alone)."""
    probe = (
        "import resource, subprocess, sys, time\n"
        "t = time.perf_counter()\n"
        "r = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)\n"
        "wall = time.perf_counter() - t\n"
        "if r.returncode != 0:\n"
        "    sys.stderr.write(r.stderr.decode()); sys.exit(r.returncode)\n"
        "print(wall, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", probe, *cmd], check=True, capture_output=True, text=True
    ).stdout.split()
    return float(out[0]), float(out[1]) / 1024.0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--armcal", default=os.path.join(
        os.environ.get("CARGO_TARGET_DIR", "target"), "release", "armcal"))
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--report-only", action="store_true",
                        help="print the table, exit 0 whatever the budgets")
    args = parser.parse_args()
    armcal = args.armcal
    with tempfile.TemporaryDirectory() as tmp:
        big = os.path.join(tmp, "session-1e6.csv")
        small = os.path.join(tmp, "session-1e5.csv")
        t = time.perf_counter()
        subprocess.run([armcal, "simulate", "--model", "puma560", "--poses", "1000000",
                        "--seed", "1", "--out", big], check=True, stdout=subprocess.DEVNULL)
        print(f"simulated 10^6 positions in {time.perf_counter() - t:.1f} s "
              f"({os.path.getsize(big) / 1e6:.0f} MB of CSV)")
        # The first 10⁵ data rows with the comment and header lines.
        with open(big) as src, open(small, "w") as dst:
            rows = 0
            for line in src:
                dst.write(line)
                if line[0].isdigit() or line[0] == "-":
                    rows += 1
                    if rows == 100_000:
                        break
        # The most rows a measurement file holds, each as short as a row is:
        # 10⁵ configurations (q1 in steps of 60 µrad) at 30 values of q2.
        short = os.path.join(tmp, "short-3e6.csv")
        with open(short, "w") as dst:
            dst.write("q1,q2,q3,q4,q5,q6,x,y,z\n")
            for k in range(30):
                q2 = f"{0.01 * k:.2f}"
                dst.write("".join(
                    f"{q1},{q2},0.3,0.4,0.5,0.6,{q1},{q2},{q1}\n"
                    for q1 in (f"{-3 + 6e-5 * i:.5f}" for i in range(100_000))))
        cases = {
            "simulate 10^6": [armcal, "simulate", "--model", "puma560", "--poses", "1000000",
                              "--seed", "1", "--out", os.path.join(tmp, "again.csv")],
            "identify 10^6": [armcal, "identify", "--model", "puma560", "--data", big],
            "diagnose 10^6": [armcal, "diagnose", "--model", "puma560", "--data", big],
            "diagnose 10^5": [armcal, "diagnose", "--model", "puma560", "--data", small],
            "check 10^6": [armcal, "check", "--model", "puma560", "--data", big],
            "check 3*10^6 short rows": [armcal, "check", "--model", "ur5e", "--data", short],
            "plan 30 of 10^4": [armcal, "plan", "--model", "ur10e", "--poses", "30",
                                "--candidates", "10000", "--out", os.path.join(tmp, "plan.csv")],
            "plan 30 of 10^5": [armcal, "plan", "--model", "ur10e", "--poses", "30",
                                "--candidates", "100000", "--out", os.path.join(tmp, "plan.csv")],
        }
        failed = False
        print(f"| run (best of {args.runs}) | wall s | budget | peak MB | budget |")
        print("| --- | --- | --- | --- | --- |")
        for name, cmd in cases.items():
            results = [run(cmd) for _ in range(args.runs)]
            wall = min(r[0] for r in results)
            peak = min(r[1] for r in results)
            seconds, mb = BUDGETS[name]
            over = (seconds is not None and wall > seconds) or (mb is not None and peak > mb)
            failed |= over
            show = lambda b, unit: "—" if b is None else f"≤ {b:g} {unit}"
            print(f"| {name} | {wall:.2f} | {show(seconds, 's')} | {peak:.0f} | "
                  f"{show(mb, 'MB')} |{' OVER BUDGET' if over else ''}")
        return 1 if failed and not args.report_only else 0


if __name__ == "__main__":
    sys.exit(main())
