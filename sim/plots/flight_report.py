#!/usr/bin/env python3
"""The figures of one closed-loop flight beside the thesis' (sec. 8.4) and Oh et al.'s.

    python3 sim/plots/flight_report.py RUN_DIR [--markdown]
    python3 sim/plots/flight_report.py RUN_DIR --target avr|cortex-m4 --image ELF --host-run HOST_DIR [--markdown]

Reads RUN_DIR/summary.json and RUN_DIR/log.csv (quad_sim's outputs), prints the comparison table
(plain text, or Markdown with --markdown) and writes it to RUN_DIR/report.txt. Exit code 1 when the run
folder is incomplete or the vehicle crashed.

With --target the run flew a board's image on its emulated processor: the table gets a column for the
host firmware's flight HOST_DIR (same scenario and seed), and a second table gives the loop timing of
both: iterations, iteration cycles (avr_pil's counts on the emulated ATmega2560; each stage of the
iteration below), overruns of the period, the firmware's own overrun report, and RAM with the peak
stack (data and bss from the image, the stack as avr_pil saw it), all read from each run's
firmware.log and events.log.
"""
import csv
import json
import os
import re
import subprocess
import sys

BAND_M = 0.05  # "altitude within 5 cm of 1.5 m"


def climb_command_time(events_path):
    with open(events_path) as f:
        for line in f:
            parts = line.split(None, 1)
            if len(parts) == 2 and parts[1].startswith("gcs: setpoint"):
                return float(parts[0])
    return None


def option(name):
    return sys.argv[sys.argv.index(name) + 1] if name in sys.argv[:-1] else None


def figures(run):
    """(summary, rows of (figure, value)) of one run folder."""
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
    return s, [
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


def table(header, rows, markdown):
    if markdown:
        lines = ["| " + " | ".join(header) + " |", "| " + " | ".join("---" for _ in header) + " |"]
        lines += ["| " + " | ".join(r) + " |" for r in rows]
    else:
        widths = [max(len(r[i]) for r in rows + [header]) for i in range(len(header))]
        fmt = lambda r: "  ".join(c.ljust(widths[i]) for i, c in enumerate(r)).rstrip()
        lines = [fmt(header), "  ".join("-" * w for w in widths)] + [fmt(r) for r in rows]
    return "\n".join(lines) + "\n"


AVR_HZ = 16e6
PROFILE = re.compile(r"avr_pil: cycles of (.+?): (\d+) samples, median (\d+), p99 (\d+), max (\d+) \(iteration (\d+)\)")
OVERRUNS = re.compile(r"avr_pil: overruns of (.+?): (\d+) of (\d+) \(([\d.]+) %\) over the (\d+)-cycle period")
HOST_LOOP = re.compile(r"quad_firmware: loop: (\d+) iterations, (\d+) overruns, longest (\d+) us of a (\d+) us period")


def read(path):
    try:
        with open(path) as f:
            return f.read()
    except OSError:
        return ""


def overrun_report(run):
    """Time and text of the firmware's first overrun STATUSTEXT in events.log, or 'none'."""
    for line in read(os.path.join(run, "events.log")).splitlines():
        if "loop overrun:" in line:
            t, _, text = line.strip().partition(" ")
            return f"at {float(t):.2f} s: {text.split(': ', 1)[-1]}"
    return "none"


def static_ram(target, image):
    """data + bss of the image (avr-size / arm-none-eabi-size), or None."""
    tool = "avr-size" if target == "avr" else "arm-none-eabi-size"
    try:
        out = subprocess.run([tool, image], capture_output=True, text=True, check=True).stdout.splitlines()
        text, data, bss = (int(x) for x in out[1].split()[:3])
        return data, bss
    except (OSError, subprocess.CalledProcessError, IndexError, ValueError):
        return None


def loop_timing(run, host_run, target, image):
    """Rows (figure, board, host) of the loop timing of both flights, and rows of the board's stages."""
    log = read(os.path.join(run, "firmware.log"))
    profiles = {m.group(1): [int(x) for x in m.groups()[1:]] for m in PROFILE.finditer(log)}
    overruns = {m.group(1): m.groups()[1:] for m in OVERRUNS.finditer(log)}
    host = HOST_LOOP.search(read(os.path.join(host_run, "firmware.log")))
    cycles = lambda p: f"{p[1]} / {p[2]} / {p[3]} cycles ({p[1] / AVR_HZ * 1e3:.2f} / {p[2] / AVR_HZ * 1e3:.2f} / {p[3] / AVR_HZ * 1e3:.2f} ms)"
    over = lambda o: f"{o[0]} of {o[1]} ({float(o[2]):.2f} %) over {o[3]} cycles"
    no_cycles = "- (QEMU does not time instructions)" if target == "cortex-m4" else "- (no avr_pil profile in firmware.log)"
    host_it = f"{host.group(1)}" if host else "-"
    host_longest = f"longest {host.group(3)} us of {host.group(4)} us (CPU time)" if host else "-"
    rows = [
        ("iterations", str(profiles["whole iteration"][0]) if "whole iteration" in profiles else "-", host_it),
        ("iteration median / p99 / max", cycles(profiles["whole iteration"]) if "whole iteration" in profiles else no_cycles, host_longest),
        ("iteration flown median / p99 / max",
         cycles(profiles["whole iteration flown"]) if "whole iteration flown" in profiles else no_cycles, "-"),
        ("iteration + fixes fused after it, flown: median / p99 / max",
         cycles(profiles["iteration and fixes after it flown"]) if "iteration and fixes after it flown" in profiles else no_cycles, "-"),
        ("iterations over the period (all)", over(overruns["whole iteration"]) if "whole iteration" in overruns else "-",
         f"{host.group(2)} overruns" if host else "-"),
        ("iterations over the period (flown)", over(overruns["whole iteration flown"]) if "whole iteration flown" in overruns else "-", "-"),
        ("periods whose iteration + fixes overran (flown)", over(overruns["iteration and fixes after it flown"]) if "iteration and fixes after it flown" in overruns else "-", "-"),
        ("firmware's overrun STATUSTEXT", overrun_report(run), overrun_report(host_run)),
    ]
    stack = re.search(r"avr_pil: peak stack (\d+) bytes", log)
    ram = static_ram(target, image)
    if ram:
        data, bss = ram
        if stack:
            total = data + bss + int(stack.group(1))
            rows.append(("RAM: data + bss + peak stack", f"{data} + {bss} + {stack.group(1)} = {total} bytes of 7168", "-"))
        else:
            rows.append(("RAM: data + bss (stack not measured)", f"{data} + {bss} = {data + bss} bytes", "-"))
    stages = [(name[len("stage "):], cycles(p)) for name, p in profiles.items() if name.startswith("stage ")]
    return rows, stages


def main():
    args = [a for i, a in enumerate(sys.argv[1:], 1)
            if not a.startswith("--") and sys.argv[i - 1] not in ("--target", "--image", "--host-run")]
    markdown = "--markdown" in sys.argv
    target, image, host_run = option("--target"), option("--image"), option("--host-run")
    if len(args) != 1 or (target is not None and (image is None or host_run is None)):
        sys.exit(__doc__)
    run = args[0]
    s, rows = figures(run)
    if target is None:
        header = ("figure", f"this run ({s['scenario']}, seed {s['seed']})", "thesis sec. 8.4", "Oh et al.")
        text = table(header, rows, markdown)
    else:
        hs, host_rows = figures(host_run)
        header = ("figure", f"{target} image ({s['scenario']}, seed {s['seed']})",
                  f"host firmware ({hs['scenario']}, seed {hs['seed']})", "thesis sec. 8.4", "Oh et al.")
        rows = [(r[0], r[1], h[1], r[2], r[3]) for r, h in zip(rows, host_rows)]
        timing, stages = loop_timing(run, host_run, target, image)
        text = table(header, rows, markdown)
        text += f"\nloop timing ({target} image: {run}; host: {host_run})\n"
        text += table(("figure", f"{target} image", "host firmware"), timing, markdown)
        if stages:
            text += "\nstages of the iteration on the emulated ATmega2560 (median / p99 / max)\n"
            text += table(("stage", "cycles"), stages, markdown)
    sys.stdout.write(text)
    with open(os.path.join(run, "report.md" if markdown else "report.txt"), "w") as f:
        f.write(text)
    ok = lambda summary: summary.get("complete") and not summary["crashed"]
    return 0 if ok(s) and (target is None or ok(hs)) else 1


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
