#!/usr/bin/python3
"""The vision station's star attitude against the simulator's truth, from a run folder.

    tools/ulog/star_attitude_vs_truth.py RUN [--from 15] [--to 75]

Reads the firmware's log (RUN/log_001.ulg, topic vision_fix: q = the star in body FRD, timestamp_sample
= the capture time) and the truth (RUN/log.csv at 100 Hz, true_roll/pitch/yaw). The star's axes are NED
(x north, z down), so q_BS* is the vehicle's attitude as the star shows it; its roll, pitch and yaw minus
the truth's, interpolated at the capture time, are printed as mean ± std over the fixes captured in
[from, to] s. The firmware's clock is the simulator's (lockstep HIL): checked against the logged estimate.
"""
import argparse
import csv
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ulog import ULog  # noqa: E402


def euler_of_q_sb(q):
    """Roll, pitch, yaw (ZYX) of R_IB = R(q_BS)ᵀ for q_BS = (w, x, y, z)."""
    w, x, y, z = q[0], -q[1], -q[2], -q[3]  # the conjugate: q_SB, read as q_IB
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run")
    ap.add_argument("--from", dest="t0", type=float, default=15.0)
    ap.add_argument("--to", dest="t1", type=float, default=75.0)
    a = ap.parse_args()
    ulg = os.path.join(a.run, "log_001.ulg")
    fix = ULog(ulg).topic("vision_fix")
    with open(os.path.join(a.run, "log.csv")) as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"{a.run}/log.csv: no rows")
    t = np.array([float(r["t"]) for r in rows])
    truth = np.array([[float(r["true_roll"]), float(r["true_pitch"]), float(r["true_yaw"])] for r in rows])
    errors = []
    for ts, q in zip(fix["timestamp_sample"], fix["q"]):
        tc = ts * 1e-6
        if not (a.t0 <= tc <= a.t1) or not np.all(np.isfinite(q)) or abs(np.dot(q, q) - 1.0) > 0.1:
            continue
        if q[0] == 1.0 and not np.any(q[1:]):
            continue  # identity: no attitude in this fix
        est = euler_of_q_sb(q)
        tru = [np.interp(tc, t, truth[:, 0]), np.interp(tc, t, truth[:, 1]), np.interp(tc, t, np.unwrap(truth[:, 2]))]
        e = [(est[i] - tru[i] + math.pi) % (2 * math.pi) - math.pi for i in range(3)]
        errors.append(np.degrees(e))
    if not errors:
        sys.exit(f"{ulg}: no fix with an attitude captured in [{a.t0}, {a.t1}] s")
    e = np.array(errors)
    print(f"{a.run}: {len(e)} fixes with an attitude, capture time {a.t0:g}-{a.t1:g} s (star minus truth)")
    for i, name in enumerate(("roll", "pitch", "yaw")):
        print(f"  {name:5s} {e[:, i].mean():+.3f} ± {e[:, i].std():.3f} deg  (median {np.median(e[:, i]):+.3f})")
    print(f"  tilt RMS {math.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2)):.3f} deg")


if __name__ == "__main__":
    main()
