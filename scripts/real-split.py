#!/usr/bin/env python3
"""The real-data figures of the README: each real set bundled in data/
split as a user validating a calibration would split it
(every third data row held out), `armcal diagnose --out` on the rest, `armcal
predict` on the held-out joints, and the RMS of the 3-D position error against
the measured points (mm), beside the nominal model's (`armcal check` on the
held-out rows). Run from the repository root after `cargo build --release`.

Environment: ARMCAL (the binary), REAL (the folder of the sets, default the
repository's data/; each set a folder with measurements.csv and its
model.toml, or a built-in model of its name), 
EXTRA (more diagnose arguments)."""
import csv, math, os, subprocess, sys, tempfile, re, time

ARMCAL = os.environ.get("ARMCAL", "target/release/armcal")
REAL = os.environ.get("REAL", "data")
SETS = sys.argv[1:] or ["figaroh-tiago-mocap", "figaroh-talos-left-arm", "figaroh-ur10e-camera"]
EXTRA = os.environ.get("EXTRA", "").split()

def split(path):
    lines = open(path).read().splitlines()
    comments, header, rows = [], None, []
    for l in lines:
        if l.startswith("#") or not l.strip():
            if header is None: comments.append(l)
            continue
        if header is None: header = l; continue
        rows.append(l)
    train = [r for i, r in enumerate(rows) if (i + 1) % 3 != 0]
    test = [r for i, r in enumerate(rows) if (i + 1) % 3 == 0]
    return comments, header, train, test

for name in SETS:
    d = os.path.join(REAL, name)
    comments, header, train, test = split(os.path.join(d, "measurements.csv"))
    tmp = tempfile.mkdtemp()
    tr = os.path.join(tmp, "train.csv"); te = os.path.join(tmp, "test.csv")
    open(tr, "w").write("\n".join(comments + [header] + train) + "\n")
    open(te, "w").write("\n".join([header] + test) + "\n")
    # A set's own model.toml, or the built-in model of its name (data/'s sets).
    model = os.path.join(d, "model.toml")
    model_text = open(model).read() if os.path.exists(model) else open(os.path.join("models", name + ".toml")).read()
    if not os.path.exists(model):
        model = name
    chk = subprocess.run([ARMCAL, "check", "--model", model, "--data", te], capture_output=True, text=True)
    m = re.search(r"= rms ([0-9.]+) mm", chk.stdout)
    nominal = float(m.group(1)) if m else float("nan")
    cal = os.path.join(tmp, "cal"); js = os.path.join(tmp, "r.json"); pred = os.path.join(tmp, "p.csv")
    t0 = time.time()
    r = subprocess.run([ARMCAL, "diagnose", "--model", model, "--data", tr, "--out", cal, "--json", js] + EXTRA, capture_output=True, text=True)
    dt = time.time() - t0
    if r.returncode != 0:
        print(f"{name}: diagnose failed: {r.stderr.strip()}"); continue
    r = subprocess.run([ARMCAL, "predict", "--calibration", cal, "--joints", te, "--out", pred], capture_output=True, text=True)
    if r.returncode != 0:
        print(f"{name}: predict failed: {r.stderr.strip()}"); continue
    hdr = header.split(",")
    ix = [hdr.index(c) for c in "xyz"]
    meas = [[float(row.split(",")[i]) for i in ix] for row in test]
    prows = [l for l in open(pred).read().splitlines() if l and not l.startswith("#")]
    ph = prows[0].split(","); pix = [ph.index(c) for c in "xyz"]
    p = [[float(l.split(",")[i]) for i in pix] for l in prows[1:]]
    unit = 1000.0 if "length_unit = \"m\"" in model_text else 1.0
    e = [math.dist(a, b) * unit for a, b in zip(meas, p)]
    rms = math.sqrt(sum(x * x for x in e) / len(e))
    import json
    rep = json.load(open(js))
    eff = [f["name"] + str(f["joints"]) for f in rep.get("effects", [])]
    print(f"{name:26s} train {len(train):3d} test {len(test):3d} nominal {nominal:8.3f} armcal {rms:8.3f} mm  ({dt:.1f}s) effects {eff} outliers {rep.get('outlier_rows')} {rep.get('chosen','')}")
