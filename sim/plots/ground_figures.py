#!/usr/bin/env python3
"""The estimate on the ground and at lift-off, from one run folder's log.csv (quad_sim's output).

    python3 sim/plots/ground_figures.py RUN_DIR [RUN_DIR ...]

Per take-off:
  - ground height error: estimate - truth (down, so + is an estimate below the vehicle), mean over the
    last 0.5 s standing before the lift-off;
  - lift-off jump: the largest step of the estimate's error in the 10 s after the lift-off, 3-D: at each
    new LOCAL_POSITION_NED sample (10 Hz) its error against the truth less the error of the sample before
    it (held in the log until then, 0.1 s earlier). An estimate that tracks steps with the truth (0); one
    that sat still while the vehicle climbed and then snapped to a fix steps by what it had missed.
Per landing (the truth back on the ground after a flight):
  - ground move: the largest 3-D distance of the estimate from its value at the disarm (the HEARTBEAT's
    armed flag, 1 Hz, so up to a second late), over the 30 s after it, or until the next lift-off or the
    end of the run, whichever is first (the window is printed);
  - the same from the touchdown itself (the land detector's LAND_TIME and the hold's still time included);
  - the estimate's 3-D error against the truth at the end of that window.

The truth is on the ground while its down coordinate is within 2 cm of where the vehicle stood at the
start of the run. tools/campaigns/run.py reads these functions for the campaigns' derived figures.
"""
import csv
import math
import os
import sys

GROUND_BAND_M = 0.02
BEFORE_LIFTOFF_S = 0.5
AFTER_LIFTOFF_S = 10.0
GROUND_WINDOW_S = 30.0
SAMPLE_PERIOD_S = 0.1  # LOCAL_POSITION_NED at TEL_POS_HZ 10


def read_log(run):
    with open(os.path.join(run, "log.csv")) as f:
        rows = list(csv.DictReader(f))
    return [{
        "t": float(r["t"]),
        "true": tuple(float(r[k]) for k in ("true_n", "true_e", "true_d")),
        "est": tuple(float(r[k]) for k in ("est_n", "est_e", "est_d")),
        "armed": r["armed"] not in ("0", "false", ""),
    } for r in rows]


def _dist(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)))


def _phases(log):
    """[(index, airborne)] at every change between standing and flying (the first row included)."""
    if not log:
        return []
    rest_d = log[0]["true"][2]
    out = [(0, False)]
    for i, r in enumerate(log):
        up = r["true"][2] < rest_d - GROUND_BAND_M
        if up != out[-1][1]:
            out.append((i, up))
    return out


def take_offs(log):
    """[(index of the lift-off, ground height error m, lift-off jump m)] for every lift-off."""
    result = []
    for i, up in _phases(log):
        if not up:
            continue
        before = [x["est"][2] - x["true"][2] for x in log[:i]
                  if x["t"] >= log[i]["t"] - BEFORE_LIFTOFF_S and not math.isnan(x["est"][2])]
        result.append((i, sum(before) / len(before) if before else float("nan"), _liftoff_jump(log, i)))
    return result


def _liftoff_jump(log, start):
    t_end = log[start]["t"] + AFTER_LIFTOFF_S
    worst = 0.0
    j = start
    for i in range(start + 1, len(log)):
        r = log[i]
        if r["t"] > t_end:
            break
        if r["est"] == log[i - 1]["est"]:
            continue
        while j + 1 < i and log[j + 1]["t"] <= r["t"] - SAMPLE_PERIOD_S + 1e-6:
            j += 1
        old = log[j]
        step = tuple((e1 - t1) - (e0 - t0) for e1, t1, e0, t0 in zip(r["est"], r["true"], old["est"], old["true"]))
        if not any(math.isnan(x) for x in step):
            worst = max(worst, math.sqrt(sum(x * x for x in step)))
    return worst


def landings(log):
    """[{touchdown_s, disarm_s, window_s, move_m, move_from_touchdown_m, error_m}] for every landing."""
    phases = _phases(log)
    result = []
    for k, (i, up) in enumerate(phases):
        if up or i == 0:
            continue
        end = phases[k + 1][0] if k + 1 < len(phases) else len(log)  # the next lift-off
        disarm = next((n for n in range(i, end) if not log[n]["armed"]), None)
        if disarm is None:
            continue
        t0 = log[disarm]["t"]
        window = [x for x in log[disarm:end] if x["t"] <= t0 + GROUND_WINDOW_S]
        since_touchdown = [x for x in log[i:end] if x["t"] <= t0 + GROUND_WINDOW_S]
        result.append({
            "touchdown_s": log[i]["t"], "disarm_s": t0, "window_s": window[-1]["t"] - t0,
            "move_m": max(_dist(x["est"], log[disarm]["est"]) for x in window),
            "move_from_touchdown_m": max(_dist(x["est"], log[i]["est"]) for x in since_touchdown),
            "error_m": _dist(window[-1]["est"], window[-1]["true"]),
        })
    return result


def main(argv):
    if len(argv) < 2:
        print("usage: ground_figures.py RUN_DIR [RUN_DIR ...]", file=sys.stderr)
        return 2
    for run in argv[1:]:
        log = read_log(run)
        print(run)
        for n, (i, err, jump) in enumerate(take_offs(log), 1):
            print(f"  take-off {n} at {log[i]['t']:.2f} s: ground height error {100 * err:+.2f} cm, "
                  f"lift-off jump {100 * jump:.2f} cm")
        for n, g in enumerate(landings(log), 1):
            print(f"  landing {n}: touchdown {g['touchdown_s']:.2f} s, disarmed {g['disarm_s']:.2f} s; in the "
                  f"{g['window_s']:.1f} s after the disarm the estimate moved {100 * g['move_m']:.2f} cm "
                  f"({100 * g['move_from_touchdown_m']:.2f} cm from the touchdown), "
                  f"error at the end {100 * g['error_m']:.2f} cm")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
