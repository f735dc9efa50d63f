#!/usr/bin/env python3
"""The estimate on the ground, from one run folder's log.csv (quad_sim's output).

    python3 sim/plots/ground_figures.py RUN_DIR [RUN_DIR ...]

Per take-off: the height error of the estimate standing on the ground before it (estimate − truth,
down positive, mean over the last 0.5 s before lift-off) and the lift-off jump (the largest step of the
estimate between two LOCAL_POSITION_NED samples, less the truth's motion over the same step, 3-D, in the
10 s after lift-off). Per landing: how far the estimate moves on the ground (the largest 3-D distance from
its value at the disarm, over the 30 s after it or until the next arming or the end of the run,
whichever is first) and how long that window was.

The truth is "on the ground" while its down coordinate is within 2 cm of where the vehicle stood at the
start of the run; lift-off is the first sample above that after standing. The armed column is the
HEARTBEAT's (1 Hz), so a disarm is seen up to a second late. tools/campaigns/run.py reads these
functions for the campaigns' derived figures.
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
    out = []
    for r in rows:
        out.append({
            "t": float(r["t"]),
            "true": tuple(float(r[k]) for k in ("true_n", "true_e", "true_d")),
            "est": tuple(float(r[k]) for k in ("est_n", "est_e", "est_d")),
            "armed": r["armed"] not in ("0", "false", ""),
        })
    return out


def _dist(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)))


def take_offs(log):
    """[(index of lift-off, height error before it in m, jump in m)] for every lift-off of the run."""
    if not log:
        return []
    rest_d = log[0]["true"][2]
    result = []
    airborne = False
    for i, r in enumerate(log):
        up = r["true"][2] < rest_d - GROUND_BAND_M
        if up and not airborne:
            before = [x["est"][2] - x["true"][2] for x in log[:i]
                      if x["t"] >= r["t"] - BEFORE_LIFTOFF_S and not math.isnan(x["est"][2])]
            height_error = sum(before) / len(before) if before else float("nan")
            result.append((i, height_error, _liftoff_jump(log, i)))
        if up:
            airborne = True
        elif airborne and not r["armed"]:
            airborne = False
    return result


def _liftoff_jump(log, start):
    """The largest step of the estimate's error after log[start]: at each new LOCAL_POSITION_NED sample
    (10 Hz), its error against the truth less the error of the sample before it, 0.1 s earlier (the
    previous sample, held in the log until then), 3-D. A tracking estimate steps with the truth (0); one
    that sat still while the vehicle climbed and then snaps to a fix steps by what it had missed."""
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


def ground_periods(log):
    """[(disarm time, window s, largest 3-D move of the estimate in m)] for every disarm after a flight."""
    result = []
    flown = False
    rest_d = log[0]["true"][2] if log else 0.0
    for i, r in enumerate(log):
        if r["armed"] and r["true"][2] < rest_d - GROUND_BAND_M:
            flown = True
        if i == 0 or not flown or r["armed"] or not log[i - 1]["armed"]:
            continue
        flown = False
        t0, p0 = r["t"], r["est"]
        worst, t_last = 0.0, t0
        for x in log[i:]:
            if x["armed"] or x["t"] > t0 + GROUND_WINDOW_S:
                break
            worst = max(worst, _dist(x["est"], p0))
            t_last = x["t"]
        result.append((t0, t_last - t0, worst))
    return result


def main(argv):
    if len(argv) < 2:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    for run in argv[1:]:
        log = read_log(run)
        print(run)
        for n, (i, err, jump) in enumerate(take_offs(log), 1):
            print(f"  take-off {n} at {log[i]['t']:.2f} s: ground height error {100 * err:+.2f} cm, "
                  f"lift-off jump {100 * jump:.2f} cm")
        for n, (t0, window, move) in enumerate(ground_periods(log), 1):
            print(f"  landing {n}, disarmed at {t0:.2f} s: estimate moved {100 * move:.2f} cm in {window:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
