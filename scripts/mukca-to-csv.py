#!/usr/bin/env python3
"""Writes armcal constraint CSVs (docs/file-formats.md, "Sessions without a
tracker") from the MUKCA ball-socket data (data/mukca-ball-socket/original/data).

For each robot and each plate placement: one file <out>/<robot>/<placement>.csv
whose rows are the joint angles of hole_0.csv and hole_1.csv (rad, as
recorded), each naming the socket its ball sits in (`<placement>.0`,
`<placement>.1`), and one distance line: the two sockets are 0.050 m apart
(MUKCA: better than 0.1 mm, written as a standard uncertainty of 0.05 mm).

Usage: scripts/mukca-to-csv.py [SRC] [OUT]
(default: data/mukca-ball-socket/original/data data/mukca-ball-socket)."""
import csv, os, sys

SRC = sys.argv[1] if len(sys.argv) > 1 else "data/mukca-ball-socket/original/data"
OUT = sys.argv[2] if len(sys.argv) > 2 else "data/mukca-ball-socket"
DISTANCE_M, DISTANCE_STD_M = 0.050, 0.00005

for robot in sorted(os.listdir(SRC)):
    folder = os.path.join(SRC, robot)
    if not os.path.isdir(folder):
        continue
    os.makedirs(os.path.join(OUT, robot), exist_ok=True)
    for placement in sorted(os.listdir(folder)):
        rows = []
        for hole in (0, 1):
            path = os.path.join(folder, placement, f"hole_{hole}.csv")
            for values in csv.reader(open(path)):
                if values:
                    rows.append([v.strip() for v in values] + [f"{placement}.{hole}"])
        dof = len(rows[0]) - 1
        out = os.path.join(OUT, robot, f"{placement}.csv")
        with open(out, "w") as f:
            f.write(f"# MUKCA {robot}, plate placed '{placement}': a ball on the flange in socket 0 or 1\n")
            f.write(f"# (joint angles in rad from {robot}/{placement}/hole_0.csv and hole_1.csv, MIT, see ../README.md)\n")
            f.write(",".join(f"q{i + 1}" for i in range(dof)) + ",point\n")
            for r in rows:
                f.write(",".join(r) + "\n")
            f.write(f"distance,{placement}.0,{placement}.1,{DISTANCE_M},{DISTANCE_STD_M}\n")
        print(out, len(rows), "rows")
