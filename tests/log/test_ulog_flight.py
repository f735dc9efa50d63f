#!/usr/bin/python3
"""The flight log of a simulated flight, read by the field's reader (tests/log/CMakeLists.txt).

    test_ulog_flight.py BUILD_BIN OUT NODE

Flies tests/log/ulog_flight.yaml with quad_sim and the host firmware (the firmware logs into the run
folder), reads OUT/log_001.ulg with tools/node/ulog_check.js (@foxglove/ulog) and checks it against the
contract (docs/logging.md) and against the simulator's own record of the flight (OUT/log.csv): every topic
present with data in time order, the IMU samples and motor commands exactly those exchanged over HIL, the
logged position estimate within a few centimetres of the true position during the hold. A copy cut short
and a copy with a wrong magic must be refused with the file named. Missing node or @foxglove/ulog fails.
"""
import bisect
import csv
import json
import math
import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
CHECKER = os.path.join(ROOT, "tools", "node", "ulog_check.js")
SCENARIO = os.path.join(HERE, "ulog_flight.yaml")
TOPICS = ["sensor_combined", "sensor_mag", "vehicle_attitude", "vehicle_local_position", "vision_fix",
          "vehicle_local_position_setpoint", "actuator_motors", "vehicle_status", "loop_timing",
          "estimator_status"]
HOLD = (10.0, 14.9)        # s: the scenario's hold at 1 m (the landing is commanded at 15 s)
PERIOD_US = 10000          # the scenario's HIL period
POSITION_TOLERANCE = 0.05  # m: the estimate against the truth during the hold

failures = []


def check(condition, what):
    print(("ok    " if condition else "FAIL  ") + what)
    if not condition:
        failures.append(what)


def read_log(node, path, *series):
    args = [node, CHECKER, path]
    for topic in series:
        args += ["--series", topic]
    return subprocess.run(args, capture_output=True, text=True, timeout=60)


def sim_rows(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return [float(r["t"]) for r in rows], rows


def row_at(times, rows, t_us):
    """The simulator's row of the exchange at t_us (its HIL_SENSOR time), or None."""
    t = t_us * 1e-6
    i = bisect.bisect_left(times, t - 5e-7)
    return rows[i] if i < len(times) and abs(times[i] - t) < 5e-7 else None


def check_exchanged_values(log, times, rows):
    """sensor_combined and actuator_motors hold exactly the floats of the HIL exchange at their time. The
    simulator's row of time T holds the truth and the IMU sample of T (the HIL_SENSOR of T) and the
    commands of the period that ends at T: the answer to the HIL_SENSOR of T - period."""
    imu = log["topics"]["sensor_combined"]["series"]
    matched = [(r, row_at(times, rows, r["timestamp"])) for r in imu]
    matched = [(r, s) for r, s in matched if s is not None]
    check(len(matched) >= 0.95 * len(imu), f"sensor_combined: {len(matched)} of {len(imu)} records at a simulator step")
    worst = 0.0
    for r, s in matched:
        for i, axis in enumerate("xyz"):
            worst = max(worst, abs(r["accelerometer_m_s2"][i] - float(s["imu_a" + axis])),
                        abs(r["gyro_rad"][i] - float(s["imu_g" + axis])))
    check(worst < 1e-5, f"sensor_combined equals the simulator's IMU samples (largest difference {worst:.2e})")
    motors = log["topics"]["actuator_motors"]["series"]
    controls = [c for r in motors for c in r["control"]]
    check(all(0.0 <= c <= 1.0 for c in controls), f"actuator_motors within 0..1 ({len(motors)} records)")
    worst = 0.0
    for r in motors:
        s = row_at(times, rows, r["timestamp"] + PERIOD_US)
        if s is not None:
            worst = max([worst] + [abs(r["control"][i] - float(s[f"cmd{i}"])) for i in range(4)])
    check(worst < 1e-5, f"actuator_motors equals the commands the simulator received (largest difference {worst:.2e})")


def check_hold(log, times, rows):
    """The logged estimate against the simulator's true position during the hold."""
    errors = []
    for r in log["topics"]["vehicle_local_position"]["series"]:
        if not HOLD[0] <= r["timestamp"] * 1e-6 <= HOLD[1]:
            continue
        s = row_at(times, rows, r["timestamp"])
        if s is not None:
            errors.append(math.dist((r["x"], r["y"], r["z"]),
                                    (float(s["true_n"]), float(s["true_e"]), float(s["true_d"]))))
    check(len(errors) > 400, f"vehicle_local_position: {len(errors)} records in the hold matched to the truth")
    worst = max(errors) if errors else float("inf")
    check(worst < POSITION_TOLERANCE, f"position estimate within {POSITION_TOLERANCE} m of the truth in the hold "
                                      f"(largest {worst:.3f} m)")
    height = [r["z"] for r in log["topics"]["vehicle_local_position_setpoint"]["series"]
              if HOLD[0] <= r["timestamp"] * 1e-6 <= HOLD[1]]
    check(bool(height) and all(abs(z + 1.0) < 1e-6 for z in height), "setpoint z = -1 m during the hold")


def check_contract(log):
    for topic in TOPICS:
        t = log["topics"].get(topic)
        check(t is not None and t["count"] > 0, f"{topic}: present with data ({t['count'] if t else 0} records)")
        if t is not None:
            check(t["monotonic"], f"{topic}: timestamps never decrease in file order")
            check(log["library_counts"].get(topic, 0) == t["count"], f"{topic}: the library's index counts the same")
    params = log["parameters"]
    check(params.get("SYS_LOOP_HZ") == 100.0, f"parameter SYS_LOOP_HZ = 100 ({params.get('SYS_LOOP_HZ')})")
    check(params.get("LOG_MODE") == 1.0, "parameter LOG_MODE = 1")
    check(log["info"].get("sys_name") == "quad-stereo" and log["info"].get("ver_hw") == "host",
          f"info sys_name, ver_hw ({log['info']})")
    check(log["info"].get("loop_hz") == 100, "info loop_hz = 100")
    status = log["topics"]["vehicle_status"]
    check(status["first"]["arming_state"] == 1 and status["last"]["arming_state"] == 0,
          "vehicle_status: armed at the start, disarmed at the end (one log per flight)")
    texts = [m["text"] for m in log["logged"]]
    check(any("LANDING" in t for t in texts) and any(t.startswith("DISARMED") for t in texts),
          f"logged strings: the mode changes ({texts})")
    fixes = log["topics"]["vision_fix"]
    seconds = (fixes["last_timestamp"] - fixes["first_timestamp"]) * 1e-6
    check(fixes["count"] > 25 * seconds, f"vision_fix: {fixes['count']} records in {seconds:.1f} s (fixes at 30 Hz)")
    check(log["topics"]["loop_timing"]["count"] >= int(seconds) - 1, "loop_timing: about once a second")
    health = log["topics"]["estimator_status"]
    check(health["count"] >= 4 * int(seconds), f"estimator_status: {health['count']} records in {seconds:.1f} s (5 Hz)")
    # The last record is on the ground after the landing (the log closes at disarming): no fix, held.
    check((health["last"]["solution_status_flags"] & 1) == 1, "estimator_status: ATTITUDE at the end")


def check_refused(node, out, good):
    data = open(good, "rb").read()
    cut = os.path.join(out, "cut.ulg")
    with open(cut, "wb") as f:
        f.write(data[: len(data) - 20])
    r = read_log(node, cut)
    check(r.returncode == 1 and cut in r.stderr and "truncated" in r.stderr,
          f"a log cut short is refused naming the file ({r.stderr.strip()})")
    bad = os.path.join(out, "bad_magic.ulg")
    with open(bad, "wb") as f:
        f.write(b"XLog" + data[4:])
    r = read_log(node, bad)
    check(r.returncode == 1 and bad in r.stderr, f"a wrong magic is refused naming the file ({r.stderr.strip()})")


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    bin_dir, out, node = sys.argv[1:]
    if not os.path.isdir(os.path.join(ROOT, "tools", "node", "node_modules", "@foxglove", "ulog")):
        sys.exit("tools/node/node_modules/@foxglove/ulog is missing: run npm install in tools/node (make setup)")
    shutil.rmtree(out, ignore_errors=True)
    sim = subprocess.run([os.path.join(bin_dir, "quad_sim"), "--scenario", SCENARIO, "--out", out, "--no-plots",
                          "--quiet"], capture_output=True, text=True, timeout=120)
    if sim.returncode != 0:
        sys.exit(f"quad_sim failed ({sim.returncode}):\n{sim.stderr}")
    logs = sorted(f for f in os.listdir(out) if f.endswith(".ulg"))
    check(logs == ["log_001.ulg"], f"one flight, one log: {logs}")
    path = os.path.join(out, "log_001.ulg")
    r = read_log(node, path, "sensor_combined", "vehicle_local_position", "vehicle_local_position_setpoint",
                 "actuator_motors")
    if r.returncode != 0:
        sys.exit(f"ulog_check failed on {path}:\n{r.stderr}")
    log = json.loads(r.stdout)
    times, rows = sim_rows(os.path.join(out, "log.csv"))
    check_contract(log)
    check_exchanged_values(log, times, rows)
    check_hold(log, times, rows)
    check_refused(node, out, path)
    if failures:
        sys.exit(f"{len(failures)} check(s) failed")


if __name__ == "__main__":
    main()
