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


def shade_hold(ax, run_dir):
    try:
        with open(os.path.join(run_dir, "summary.json")) as f:
            hold = json.load(f).get("hold", {})
        if hold.get("end_s", 0) > hold.get("start_s", 0):
            ax.axvspan(hold["start_s"], hold["end_s"], color="0.92", zorder=0)
    except (OSError, ValueError):
        pass


def time_plot(run_dir, cols, name, rows, ylabel_unit):
    fig, axes = plt.subplots(len(rows), 1, sharex=True, figsize=(10, 2.6 * len(rows)))
    t = cols["t"]
    for ax, (label, series) in zip(axes, rows):
        shade_hold(ax, run_dir)
        for key, style, legend, scale in series:
            if key in cols:
                ax.plot(t, [scale * v for v in cols[key]], style, label=legend, linewidth=1.0)
        ax.set_ylabel(f"{label} [{ylabel_unit}]")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    axes[-1].set_xlabel("simulated time [s]")
    fig.suptitle(title_of(run_dir), fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(run_dir, name), dpi=110)
    plt.close(fig)


def main():
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    run_dir = sys.argv[1]
    cols = read_log(os.path.join(run_dir, "log.csv"))
    deg = 180.0 / math.pi

    time_plot(run_dir, cols, "position.png", [
        (axis, [(f"true_{k}", "-", "truth", 1.0), (f"est_{k}", "--", "firmware estimate", 1.0),
                (f"sp_{k}", ":", "setpoint", 1.0)])
        for axis, k in (("north", "n"), ("east", "e"), ("down", "d"))], "m")
    time_plot(run_dir, cols, "velocity.png", [
        (axis, [(f"true_v{k}", "-", "truth", 1.0), (f"est_v{k}", "--", "firmware estimate", 1.0)])
        for axis, k in (("v north", "n"), ("v east", "e"), ("v down", "d"))], "m/s")
    time_plot(run_dir, cols, "attitude.png", [
        (axis, [(f"true_{k}", "-", "truth", deg), (f"est_{k}", "--", "firmware estimate", deg)]
         + ([("sp_yaw", ":", "setpoint", deg)] if k == "yaw" else []))
        for axis, k in (("roll", "roll"), ("pitch", "pitch"), ("yaw", "yaw"))], "deg")
    time_plot(run_dir, cols, "motors.png", [
        ("command", [(f"cmd{i}", "-", f"motor {i}", 1.0) for i in range(4)]),
        ("thrust", [(f"thrust{i}", "-", f"motor {i}", 1.0) for i in range(4)])], "0..1 / N")

    # Estimate against truth.
    fig, ax = plt.subplots(figsize=(10, 3.5))
    shade_hold(ax, run_dir)
    for k, label in (("n", "north"), ("e", "east"), ("d", "down")):
        err = [e - tr for e, tr in zip(cols[f"est_{k}"], cols[f"true_{k}"])]
        ax.plot(cols["t"], [100 * v for v in err], label=label, linewidth=1.0)
    ax.set_ylabel("estimate - truth [cm]")
    ax.set_xlabel("simulated time [s]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title_of(run_dir), fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(run_dir, "estimate_error.png"), dpi=110)
    plt.close(fig)

    # XY track (east to the right, north up), with the star at the origin.
    fig, ax = plt.subplots(figsize=(6, 6))
    ax.plot(cols["true_e"], cols["true_n"], "-", linewidth=1.0, label="truth")
    ax.plot(cols["est_e"], cols["est_n"], "--", linewidth=0.8, label="firmware estimate")
    sp = [(e, n) for e, n in zip(cols["sp_e"], cols["sp_n"]) if not math.isnan(e)]
    if sp:
        ax.plot([p[0] for p in sp], [p[1] for p in sp], "k:", linewidth=1.0, label="setpoint")
    ax.plot([0], [0], "k*", markersize=14, label="star (NED origin)")
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title_of(run_dir), fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(run_dir, "track.png"), dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
