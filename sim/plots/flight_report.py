#!/usr/bin/env python3
"""The figures of one closed-loop flight beside the thesis' (sec. 8.4) and Oh et al.'s.

    python3 sim/plots/flight_report.py RUN_DIR [--markdown]

Reads RUN_DIR/summary.json and RUN_DIR/log.csv (quad_sim's outputs), prints the comparison table
(plain text, or Markdown with --markdown) and writes it to RUN_DIR/report.txt. Exit code 1 when the run
folder is incomplete or the vehicle crashed.
"""
import csv
import json
import os
import sys

BAND_M = 0.05  # "altitude within 5 cm of 1.5 m"


def climb_command_time(events_path):
    with open(events_path) as f:
        for line in f:
            parts = line.split(None, 1)
            if len(parts) == 2 and parts[1].startswith("gcs: setpoint"):
                return float(parts[0])
    return None


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    markdown = "--markdown" in sys.argv
    if len(args) != 1:
        sys.exit(__doc__)
    run = args[0]
    with open(os.path.join(run, "summary.json")) as f:
        s = json.load(f)
    hold = s["hold"]
    command_t = climb_command_time(os.path.join(run, "events.log"))
    # Settling is judged over the flight up to the end of the hold (the landing leaves the band on purpose).
    settle = None
    if command_t is not None:
        settle = altitude_settled_after_until(os.path.join(run, "log.csv"), command_t, hold["end_s"])
    st = s.get("vision_station", {})
    fe = st.get("fix_error_m", {})
    pt = st.get("processing_us", {})
    n, e, v, h = hold["north"], hold["east"], hold["vertical"], hold["horizontal"]
    cm = lambda x: f"{100 * x:.2f} cm"
    rows = [
        ("hold window", f"{hold['end_s'] - hold['start_s']:.0f} s ({hold['start_s']:.1f}-{hold['end_s']:.1f} s)", "about 60 s", "-"),
        ("x (north) mean / std", f"{cm(n['mean'])} / {cm(n['std'])}", "within +-20 cm, std 8.5 cm", "std 10.6 cm"),
        ("y (east) mean / std", f"{cm(e['mean'])} / {cm(e['std'])}", "within +-20 cm, std 8.5 cm", "std 21.5 cm"),
        ("horizontal std (2-D) / |mean|", f"{cm(h['std_2d'])} / {cm((n['mean'] ** 2 + e['mean'] ** 2) ** 0.5)}", "-", "-"),
        ("horizontal max |error|", cm(h["max"]), "20 cm", "-"),
        ("vertical mean / std", f"{cm(v['mean'])} / {cm(v['std'])}", "-", "-"),
        ("altitude within 5 cm of 1.5 m, after the climb command",
         "never" if settle is None else f"{settle:.2f} s", "about 60 s", "-"),
        ("station fix vs truth, median / 95th pct",
         f"{1000 * fe.get('median', float('nan')):.1f} mm / {1000 * fe.get('p95', float('nan')):.1f} mm" if fe else "-", "-", "-"),
        ("station: pairs captured / lost / fixes",
         f"{st.get('pairs_captured', 0)} / {st.get('pairs_lost', 0)} / {st.get('fixes', 0)}" if st else "-", "-", "-"),
        ("station processing, median / 95th pct (wall)",
         f"{pt.get('median', 0) / 1000:.2f} ms / {pt.get('p95', 0) / 1000:.2f} ms" if pt else "-", "about 30 ms", "-"),
        ("real-time factor (whole loop, rendering included)", f"{s['real_time_factor']:.2f}x", "-", "-"),
        ("crashed", "yes" if s["crashed"] else "no", "-", "-"),
    ]
    header = ("figure", f"this run ({s['scenario']}, seed {s['seed']})", "thesis sec. 8.4", "Oh et al.")
    if markdown:
        lines = ["| " + " | ".join(header) + " |", "| --- | --- | --- | --- |"]
        lines += ["| " + " | ".join(r) + " |" for r in rows]
    else:
        widths = [max(len(r[i]) for r in rows + [header]) for i in range(4)]
        fmt = lambda r: "  ".join(c.ljust(widths[i]) for i, c in enumerate(r)).rstrip()
        lines = [fmt(header), "  ".join("-" * w for w in widths)] + [fmt(r) for r in rows]
    text = "\n".join(lines) + "\n"
    sys.stdout.write(text)
    with open(os.path.join(run, "report.md" if markdown else "report.txt"), "w") as f:
        f.write(text)
    return 0 if s.get("complete") and not s["crashed"] else 1


def altitude_settled_after_until(log_path, command_t, end_t):
    """Seconds from the climb command until |d - d_sp| stays <= BAND_M through end_t; None if never."""
    last_outside = None
    seen = False
    with open(log_path, newline="") as f:
        for row in csv.DictReader(f):
            t = float(row["t"])
            if t < command_t or t > end_t:
                continue
            sp = float(row["sp_d"])
            if sp != sp:
                continue
            seen = True
            if abs(float(row["true_d"]) - sp) > BAND_M:
                last_outside = t
    if not seen or (last_outside is not None and last_outside >= end_t - 0.01):
        return None
    return 0.0 if last_outside is None else last_outside + 0.01 - command_t


if __name__ == "__main__":
    sys.exit(main())
