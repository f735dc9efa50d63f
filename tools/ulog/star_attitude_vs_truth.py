#!/usr/bin/python3
"""The vision station's star attitude against the simulator's truth, from a run folder.

    tools/ulog/star_attitude_vs_truth.py RUN [--from 15] [--to 75]

Reads the firmware's log (RUN/log_001.ulg, topic vision_fix: q = the star in body FRD, timestamp_sample
= the capture time) and the truth (RUN/log.csv at 100 Hz, true_roll/pitch/yaw). The star's axes are NED
(x north, z down), so q_BS* is the vehicle's attitude as the star shows it; its roll, pitch and yaw minus
the truth's, interpolated at the capture time, are printed as mean ± std over the fixes captured in
[from, to] s. The firmware's clock is the simulator's (lockstep HIL): checked against the logged estimate.

With the radio's record (RUN/link.tlog, read here frame by frame: 8-byte time stamp, MAVLink v2 frame),
the station's attitude covariance (LANDING_TARGET_COVARIANCE, id 43000, matched to the fix by its
time_usec) is set against the same errors: the station's σ about body x, y, z (median) and the error over
σ (its RMS is 1 for a consistent σ). The last line is the firmware's estimate against the truth over the
same window (log.csv est_roll/est_pitch), whose mean shows how much of the fixes' bias it took.
"""
import argparse
import csv
import math
import os
import struct
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ulog import ULog  # noqa: E402

LANDING_TARGET_COVARIANCE = 43000


def euler_of_q_sb(q):
    """Roll, pitch, yaw (ZYX) of R_IB = R(q_BS)ᵀ for q_BS = (w, x, y, z)."""
    w, x, y, z = q[0], -q[1], -q[2], -q[3]  # the conjugate: q_SB, read as q_IB
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def attitude_covariances(tlog_path):
    """{time_usec: 3x3 attitude covariance (rad², body FRD)} of the record's LANDING_TARGET_COVARIANCE."""
    out = {}
    with open(tlog_path, "rb") as f:
        data = f.read()
    i = 0
    while i + 8 + 12 <= len(data):
        i += 8
        if data[i] != 0xFD:
            sys.exit(f"{tlog_path}: byte {i} is not a MAVLink v2 frame start")
        length, incompat = data[i + 1], data[i + 2]
        msgid = data[i + 7] | (data[i + 8] << 8) | (data[i + 9] << 16)
        if msgid == LANDING_TARGET_COVARIANCE:
            p = data[i + 10:i + 10 + length] + bytes(58)  # v2 trims trailing zeros
            if p[57] == 1:
                c = struct.unpack_from("<6f", p, 32)
                out[struct.unpack_from("<Q", p, 0)[0]] = np.array(
                    [[c[0], c[1], c[2]], [c[1], c[3], c[4]], [c[2], c[4], c[5]]])
        i += 10 + length + 2 + (13 if incompat & 1 else 0)
    return out


def body_error(est, tru):
    """The small rotation from the true to the measured attitude about body axes (rad), ZYX angles in."""
    def dcm(r, p, y):
        cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
        return np.array([[cp * cy, sr * sp * cy - cr * sy, cr * sp * cy + sr * sy],
                         [cp * sy, sr * sp * sy + cr * cy, cr * sp * sy - sr * cy],
                         [-sp, sr * cp, cr * cp]])
    d = dcm(*tru).T @ dcm(*est)
    return np.array([d[2, 1] - d[1, 2], d[0, 2] - d[2, 0], d[1, 0] - d[0, 1]]) / 2


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
    estimate = np.array([[float(r["est_roll"]), float(r["est_pitch"])] for r in rows])
    tlog = os.path.join(a.run, "link.tlog")
    covariances = attitude_covariances(tlog) if os.path.exists(tlog) else {}
    errors, z, sigmas = [], [], []
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
        c = covariances.get(int(ts))
        if c is not None:
            s = np.sqrt(np.diag(c))
            sigmas.append(np.degrees(s))
            z.append(body_error(est, tru) / s)
    if not errors:
        sys.exit(f"{ulg}: no fix with an attitude captured in [{a.t0}, {a.t1}] s")
    e = np.array(errors)
    print(f"{a.run}: {len(e)} fixes with an attitude, capture time {a.t0:g}-{a.t1:g} s (star minus truth)")
    for i, name in enumerate(("roll", "pitch", "yaw")):
        print(f"  {name:5s} {e[:, i].mean():+.3f} ± {e[:, i].std():.3f} deg  (median {np.median(e[:, i]):+.3f})")
    print(f"  tilt RMS {math.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2)):.3f} deg")
    if z:
        s, z = np.array(sigmas), np.array(z)
        print(f"  station's sigma (median) about body x y z: {np.median(s[:, 0]):.3f} {np.median(s[:, 1]):.3f} "
              f"{np.median(s[:, 2]):.3f} deg; error / sigma RMS {np.sqrt(np.mean(z[:, 0] ** 2)):.2f} "
              f"{np.sqrt(np.mean(z[:, 1] ** 2)):.2f} {np.sqrt(np.mean(z[:, 2] ** 2)):.2f} ({len(z)} fixes)")
    else:
        print("  no LANDING_TARGET_COVARIANCE with an attitude in the record")
    hold = (t >= a.t0) & (t <= a.t1)
    d = np.degrees(estimate[hold] - truth[hold, :2])
    print(f"  estimate minus truth: roll {d[:, 0].mean():+.3f} ± {d[:, 0].std():.3f}, pitch {d[:, 1].mean():+.3f} ± "
          f"{d[:, 1].std():.3f} deg, tilt RMS {math.sqrt(np.mean(d[:, 0] ** 2 + d[:, 1] ** 2)):.3f} deg")


if __name__ == "__main__":
    main()
