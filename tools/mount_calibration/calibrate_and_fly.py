#!/usr/bin/python3
"""The camera-mount benchmark of docs/estimation.md ("The camera mount"), one seed:

    calibrate_and_fly.py --build DIR --seed N --mount-deg ROLL,PITCH,YAW --out DIR [--hover SCENARIO]
                         [--hover-param NAME=VALUE ...] [--tool-arg ARG ...]

1. flies sim/scenarios/mount_calibration.yaml with the rendered rig turned by the mount error
   (camera.mount_error_deg), unknown to the station and the firmware;
2. runs mount_calibration on the flight's log (seed 002's R = XQY) and compares the recovered mount
   with the simulated one;
3. flies the hover (flight_plain.yaml) with the mount error and the firmware's EST_CAM_* at zero
   (uncalibrated), and again with the EST_CAM_* the tool printed (calibrated); --hover-param sets
   firmware parameters for both hovers (EST_TYPE=1: the EKF).

Prints one `[mount]` line per figure (tools/campaign reads them: sim/campaigns/mount_calibration.yaml).
Exit status: 0 done, 1 a flight or the calibration failed, 2 bad arguments.
"""
import argparse
import json
import os
import re
import subprocess
import sys


def run(cmd, log_path):
    with open(log_path, "w") as log:
        log.write(" ".join(cmd) + "\n")
        log.flush()
        r = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT)
    if r.returncode not in (0, 3):  # 3: complete, plots failed
        sys.exit(f"calibrate_and_fly: {cmd[0]} exited {r.returncode} (see {log_path})")


def hover_figures(label, run_dir):
    with open(os.path.join(run_dir, "summary.json")) as f:
        s = json.load(f)
    if not s.get("complete") or s.get("crashed"):
        sys.exit(f"calibrate_and_fly: {run_dir}: the {label} hover did not complete")
    h = s["hold"]
    mean = (h["north"]["mean"] ** 2 + h["east"]["mean"] ** 2) ** 0.5
    ev = s["estimate_vs_truth"]["hold"]
    print(f"[mount] {label} hold mean offset {100 * mean:.2f} cm (north {100 * h['north']['mean']:+.2f}, "
          f"east {100 * h['east']['mean']:+.2f})")
    print(f"[mount] {label} hold horizontal std {100 * h['horizontal']['std_2d']:.2f} cm")
    print(f"[mount] {label} estimate vs truth horizontal RMS {1000 * ev['horizontal_rms_m']:.1f} mm")
    print(f"[mount] {label} tilt error RMS {ev['tilt_rms_deg']:.3f} deg")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--build", required=True, help="the host build folder (build/host)")
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--mount-deg", required=True, help="the simulated mount error ROLL,PITCH,YAW (degrees)")
    ap.add_argument("--out", required=True, help="folder for the three runs")
    ap.add_argument("--root", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
    ap.add_argument("--hover", default="sim/scenarios/flight_plain.yaml")
    ap.add_argument("--calibration", default="sim/scenarios/mount_calibration.yaml")
    ap.add_argument("--hover-param", action="append", default=[], metavar="NAME=VALUE",
                    help="a firmware parameter for both hovers (repeatable), e.g. EST_TYPE=1")
    ap.add_argument("--tool-arg", action="append", default=[], metavar="ARG",
                    help="an argument for mount_calibration (repeatable), e.g. --free-star-yaw")
    a = ap.parse_args()
    try:
        mount = [float(x) for x in a.mount_deg.split(",")]
        if len(mount) != 3:
            raise ValueError
    except ValueError:
        ap.error(f"--mount-deg '{a.mount_deg}': expected ROLL,PITCH,YAW in degrees")
    hover_sets = []
    for p in a.hover_param:
        if not re.fullmatch(r"[A-Z][A-Z0-9_]*=\S+", p):
            ap.error(f"--hover-param '{p}': expected NAME=VALUE")
        hover_sets += ["--set", f"firmware_params.{p}"]
    sim = os.path.join(a.build, "bin", "quad_sim")
    tool = os.path.join(a.build, "bin", "mount_calibration")
    for exe in (sim, tool):
        if not os.access(exe, os.X_OK):
            ap.error(f"{exe}: not built")
    os.makedirs(a.out, exist_ok=True)
    error_key = "camera.mount_error_deg=[" + ",".join(str(x) for x in mount) + "]"
    common = ["--seed", str(a.seed), "--no-plots", "--quiet", "--set", error_key]

    cal_dir = os.path.join(a.out, "calibration")
    run([sim, "--scenario", os.path.join(a.root, a.calibration), "--out", cal_dir] + common,
        os.path.join(a.out, "calibration.txt"))
    logs = sorted(f for f in os.listdir(cal_dir) if f.endswith(".ulg"))
    if not logs:
        sys.exit(f"calibrate_and_fly: {cal_dir}: no flight log")
    r = subprocess.run([tool, os.path.join(cal_dir, logs[0]), "--expect-deg", a.mount_deg] + a.tool_arg,
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    with open(os.path.join(a.out, "mount_calibration.txt"), "w") as f:
        f.write(r.stdout)
    print(r.stdout, end="")
    if r.returncode != 0:
        sys.exit(f"calibrate_and_fly: mount_calibration exited {r.returncode}")
    params = dict(re.findall(r"^(EST_CAM_(?:ROLL|PITCH|YAW)) (\S+)$", r.stdout, re.M))
    error = re.search(r"^error against the expected mount: (\S+) deg$", r.stdout, re.M)
    if len(params) != 3 or error is None:
        sys.exit("calibrate_and_fly: mount_calibration printed no mount")
    print(f"[mount] simulated mount error {a.mount_deg} deg; recovered mount error {error.group(1)} deg from it")
    got = re.search(r"^mount: roll (\S+) pitch (\S+) yaw (\S+) deg", r.stdout, re.M)
    if got:
        d = [float(g) - m for g, m in zip(got.groups(), mount)]
        print(f"[mount] recovered minus simulated: roll {d[0]:+.3f} pitch {d[1]:+.3f} yaw {d[2]:+.3f} deg")
        print(f"[mount] recovered error by axis: roll {abs(d[0]):.3f} pitch {abs(d[1]):.3f} yaw {abs(d[2]):.3f} deg")

    plain = os.path.join(a.out, "hover_uncalibrated")
    run([sim, "--scenario", os.path.join(a.root, a.hover), "--out", plain] + common + hover_sets,
        os.path.join(a.out, "hover_uncalibrated.txt"))
    hover_figures("uncalibrated", plain)
    calibrated = os.path.join(a.out, "hover_calibrated")
    sets = list(hover_sets)
    for name, value in params.items():
        sets += ["--set", f"firmware_params.{name}={value}"]
    run([sim, "--scenario", os.path.join(a.root, a.hover), "--out", calibrated] + common + sets,
        os.path.join(a.out, "hover_calibrated.txt"))
    hover_figures("calibrated", calibrated)


if __name__ == "__main__":
    main()
