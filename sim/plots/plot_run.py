#!/usr/bin/env python3
"""Plots of one quad_sim run folder: position, velocity and attitude against time with the setpoints
and the firmware's estimate, the XY track, the estimate's error, the motor commands.

    python3 sim/plots/plot_run.py RUN_DIR        (quad_sim runs it at the end of every run)

Reads RUN_DIR/log.csv (and summary.json for the title), writes RUN_DIR/*.png. A run that was cut short
plots whatever its log holds.
"""
import csv
import json
import math
import os
import sys
from collections import namedtuple

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read_log(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if len(rows) < 2:
        raise SystemExit(f"{path}: no data rows")
    header, data = rows[0], rows[1:]
    cols = {name: [] for name in header}
    for row in data:
        if len(row) != len(header):
            break  # a row cut by an interruption
        for name, value in zip(header, row):
            cols[name].append(float(value))
    return cols


def title_of(run_dir):
    try:
        with open(os.path.join(run_dir, "summary.json")) as f:
            s = json.load(f)
    except (OSError, ValueError):
        return os.path.basename(os.path.normpath(run_dir))
    t = f"{s.get('scenario', '?')} (seed {s.get('seed', '?')})"
    if not s.get("complete", False):
        t += f" - cut short: {s.get('cut_short', '?')}"
    h = s.get("hold", {}).get("horizontal", {})
    if s.get("hold", {}).get("samples", 0):
        t += f"\nhold: horizontal std {100 * h.get('std_2d', 0):.1f} cm, rms {100 * h.get('rms', 0):.1f} cm"
    return t


# ---- Drawing (shared with tools/ulog_plots, which draws the firmware's flight log) -------------------

# One line of a plot: times (s), values (display units), matplotlib style and colour, legend. Colours are
# fixed per role, so a figure looks the same whichever series a log holds: C0 the truth, C1 the firmware's
# estimate, C2 the setpoint, C3 the vision fixes.
Series = namedtuple("Series", "t y style color label")
TRUTH, ESTIMATE, SETPOINT, FIX = "C0", "C1", "C2", "C3"


def time_figure(path, title, rows, unit, xlabel="simulated time [s]", spans=(), row_height=2.6):
    """Rows of time series sharing the time axis: rows = [(label, [Series])]; spans: shaded (start, end)."""
    fig, axes = plt.subplots(len(rows), 1, sharex=True, figsize=(10, row_height * len(rows)), squeeze=False)
    for ax, (label, series) in zip(axes[:, 0], rows):
        for start, end in spans:
            ax.axvspan(start, end, color="0.92", zorder=0)
        for s in series:
            ax.plot(s.t, s.y, s.style, color=s.color, label=s.label, linewidth=1.0, markersize=3)
        ax.set_ylabel(f"{label} [{unit}]")
        ax.grid(True, alpha=0.3)
        if series:
            ax.legend(loc="best", fontsize=8)
    axes[-1, 0].set_xlabel(xlabel)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def track_figure(path, title, lines, setpoint=None):
    """The XY track (east to the right, north up) with the star at the origin: lines = [Series] with
    t = east and y = north; setpoint: (east, north) lists or None."""
    fig, ax = plt.subplots(figsize=(6, 6))
    for s in lines:
        ax.plot(s.t, s.y, s.style, color=s.color, linewidth=1.0 if s.style == "-" else 0.8, label=s.label,
                markersize=3)
    if setpoint is not None and len(setpoint[0]):
        ax.plot(setpoint[0], setpoint[1], "k:", linewidth=1.0, label="setpoint")
    ax.plot([0], [0], "k*", markersize=14, label="star (NED origin)")
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run_spans(run_dir):
    """The hold window of a quad_sim run folder (summary.json), as time_figure's spans."""
    try:
        with open(os.path.join(run_dir, "summary.json")) as f:
            hold = json.load(f).get("hold", {})
        if hold.get("end_s", 0) > hold.get("start_s", 0):
            return [(hold["start_s"], hold["end_s"])]
    except (OSError, ValueError):
        pass
    return []


AXES = (("north", "n"), ("east", "e"), ("down", "d"))


def truth_series(cols, key, scale=1.0):
    """The simulator's truth column `true_<key>` of log.csv (empty when absent)."""
    name = f"true_{key}"
    return [Series(cols["t"], [scale * v for v in cols[name]], "-", TRUTH, "truth")] if name in cols else []


def estimate_error_rows(cols, estimate):
    """Rows of estimate - truth (cm) per NED axis, the estimate {axis key: (t, values)} interpolated onto the
    truth's times (the same times for log.csv's own estimate)."""
    import numpy as np
    rows = []
    for i, (label, k) in enumerate(AXES):
        t_est, est = estimate[k]
        est_on_truth = np.interp(cols["t"], t_est, est, left=np.nan, right=np.nan)
        err = [100 * (e - tr) for e, tr in zip(est_on_truth, cols[f"true_{k}"])]
        rows.append(Series(cols["t"], err, "-", f"C{i}", label))
    return rows


# ---- The run folder's plots ------------------------------------------------------------------------


def main():
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    run_dir = sys.argv[1]
    cols = read_log(os.path.join(run_dir, "log.csv"))
    deg = 180.0 / math.pi
    title, spans, t = title_of(run_dir), run_spans(run_dir), cols["t"]
    out = lambda name: os.path.join(run_dir, name)

    def column(key, style, color, label, scale=1.0):
        return [Series(t, [scale * v for v in cols[key]], style, color, label)] if key in cols else []

    time_figure(out("position.png"), title, [
        (axis, truth_series(cols, k) + column(f"est_{k}", "--", ESTIMATE, "firmware estimate")
         + column(f"sp_{k}", ":", SETPOINT, "setpoint")) for axis, k in AXES], "m", spans=spans)
    time_figure(out("velocity.png"), title, [
        (f"v {axis}", truth_series(cols, f"v{k}") + column(f"est_v{k}", "--", ESTIMATE, "firmware estimate"))
        for axis, k in AXES], "m/s", spans=spans)
    time_figure(out("attitude.png"), title, [
        (k, truth_series(cols, k, deg) + column(f"est_{k}", "--", ESTIMATE, "firmware estimate", deg)
         + (column("sp_yaw", ":", SETPOINT, "setpoint", deg) if k == "yaw" else []))
        for k in ("roll", "pitch", "yaw")], "deg", spans=spans)
    time_figure(out("motors.png"), title, [
        ("command", sum((column(f"cmd{i}", "-", f"C{i}", f"motor {i}") for i in range(4)), [])),
        ("thrust", sum((column(f"thrust{i}", "-", f"C{i}", f"motor {i}") for i in range(4)), []))],
        "0..1 / N", spans=spans)
    # Estimate against truth.
    estimate = {k: (t, cols[f"est_{k}"]) for _, k in AXES}
    time_figure(out("estimate_error.png"), title, [("estimate - truth", estimate_error_rows(cols, estimate))],
                "cm", spans=spans, row_height=3.5)
    sp = [(e, n) for e, n in zip(cols["sp_e"], cols["sp_n"]) if not math.isnan(e)]
    track_figure(out("track.png"), title, [
        Series(cols["true_e"], cols["true_n"], "-", TRUTH, "truth"),
        Series(cols["est_e"], cols["est_n"], "--", ESTIMATE, "firmware estimate")],
        ([p[0] for p in sp], [p[1] for p in sp]))


if __name__ == "__main__":
    main()
