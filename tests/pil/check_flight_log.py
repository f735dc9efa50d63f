#!/usr/bin/python3
"""The flight log of an APM 2.5 processor-in-the-loop flight (tests/pil/CMakeLists.txt, pil_flight_avr_100hz and
pil_flight_avr_200hz).

    check_flight_log.py NODE RUN IMAGE

RUN is the flight's run folder (quad_sim --out), IMAGE the emulated DataFlash avr_pil wrote at exit
(--dataflash). The log is taken out of the image by tools/avr_pil/dataflash_logs.py (the layout of
docs/logging.md, not the firmware's driver) and read by @foxglove/ulog (tools/node/ulog_check.js): every
topic present in time order, no dropout message, the IMU records as many as the flown iterations, loop_timing counting no
overrun in flight when avr_pil timed none. The bytes the scenario's log_download brought over the emulated
radio (RUN/log_download.ulg, summary.json log_download) must be the image's log byte for byte.
The emulated chip must have refused no command (a read of main memory while a page programs).
"""
import json
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
CHECKER = os.path.join(ROOT, "tools", "node", "ulog_check.js")
READER = os.path.join(ROOT, "tools", "avr_pil", "dataflash_logs.py")
TOPICS = ["sensor_combined", "sensor_mag", "vehicle_attitude", "vehicle_local_position", "vision_fix",
          "vehicle_local_position_setpoint", "actuator_motors", "vehicle_status", "loop_timing",
          "estimator_status"]

failures = []


def check(condition, what):
    print(("ok    " if condition else "FAIL  ") + what)
    if not condition:
        failures.append(what)


def main(node, run, image):
    if not os.path.exists(image):
        print(f"FAIL  no DataFlash image {image} (avr_pil --dataflash)")
        return 1
    listing = subprocess.run([sys.executable, READER, image, "list"], capture_output=True, text=True)
    check(listing.returncode == 0, f"dataflash_logs.py lists {image}: {listing.stdout.strip() or listing.stderr.strip()}")
    lines = listing.stdout.split("\n")
    lines = [line for line in lines if line]
    check(len(lines) == 1, f"one log in the image (one arming, LOG_MODE 1): {len(lines)}")
    if not lines:
        return 1
    log_id = lines[-1].split()[0]
    flight_log = os.path.join(run, "dataflash_log.ulg")
    extracted = subprocess.run([sys.executable, READER, image, "extract", log_id, flight_log], capture_output=True, text=True)
    check(extracted.returncode == 0, f"log {log_id} extracted to {flight_log} {extracted.stderr.strip()}")
    if extracted.returncode != 0:
        return 1
    with open(flight_log, "rb") as f:
        stored = f.read()

    read = subprocess.run([node, CHECKER, flight_log], capture_output=True, text=True, timeout=120)
    check(read.returncode == 0, f"@foxglove/ulog reads the {len(stored)}-byte log {read.stderr.strip()}")
    if read.returncode == 0:
        info = json.loads(read.stdout)
        topics = info["topics"]
        for topic in TOPICS:
            t = topics.get(topic)
            check(t is not None and t["count"] > 0 and t["monotonic"],
                  f"{topic}: {t['count'] if t else 0} records, timestamps in order")
        # The firmware writes a dropout message after records it had to drop (its writer's buffer full).
        check(info.get("dropouts", 0) == 0, f"no dropout message in the log ({info.get('dropouts', 0)})")
        with open(os.path.join(run, "firmware.log")) as f:
            firmware_log = f.read()
        flown = re.search(r"cycles of whole iteration flown: (\d+) samples", firmware_log)
        over = re.search(r"overruns of whole iteration flown: (\d+) of", firmware_log)
        imu = topics.get("sensor_combined", {}).get("count", 0)
        imu_div = 1
        with open(os.path.join(run, "firmware_params.txt")) as f:
            for line in f:
                if line.split()[:1] == ["LOG_IMU_DIV"]:
                    imu_div = int(float(line.split()[1]))
        if flown:
            # The log runs from the arming to the disarming: the flown iterations, less the definitions'
            # first iterations, plus the few on the ground at each end; every LOG_IMU_DIV-th of them.
            expected = int(flown.group(1)) / imu_div
            check(abs(imu - expected) <= 100 / imu_div,
                  f"sensor_combined records {imu} against {flown.group(1)} flown iterations / LOG_IMU_DIV {imu_div} (none dropped)")
        timing = topics.get("loop_timing")
        if timing and over:
            grew = timing["last"]["overruns"] - timing["first"]["overruns"]
            print(f"      loop_timing: overruns {timing['first']['overruns']} .. {timing['last']['overruns']}, "
                  f"max_us {timing['last']['max_us']}, records_deferred {timing['last'].get('records_deferred')}; "
                  f"avr_pil: {over.group(1)} flown iterations over the period")
            if int(over.group(1)) == 0:
                check(grew == 0, f"loop_timing counts no overrun in flight ({grew}), as avr_pil timed none")
            else:
                check(grew > 0, f"loop_timing counts the overruns avr_pil timed ({grew})")
        check("DataFlash refused" not in firmware_log, "the emulated DataFlash refused no command")

    with open(os.path.join(run, "summary.json")) as f:
        summary = json.load(f)
    download = summary.get("log_download")
    check(download is not None, "the scenario's log download ran (summary.json log_download)")
    if download is None:
        return 1
    print(f"      log download: log {download['id']}, {download['bytes_received']} of {download['wanted']} bytes "
          f"({download['listed_size']} listed) in {download['frames']} LOG_DATA, {download['data_requests']} "
          f"requests, {download['data_started_s']:.2f} .. {download['finished_s']:.2f} s, "
          f"{download['rate_bytes_s']:.0f} bytes/s over the radio")
    check(download["complete"], f"the download completed {download.get('failure', '')}")
    check(str(download["id"]) == log_id, f"it downloaded the flight's log ({download['id']})")
    with open(os.path.join(run, download["file"]), "rb") as f:
        got = f.read()
    check(len(got) == download["wanted"] and len(got) > 0, f"{len(got)} bytes downloaded, {download['wanted']} wanted")
    first_difference = next((i for i, (a, b) in enumerate(zip(got, stored)) if a != b), None)
    check(len(got) <= len(stored) and first_difference is None,
          f"the downloaded bytes are the stored log's first {len(got)} bytes"
          + ("" if first_difference is None else f" (first difference at offset {first_difference})"))
    return 1 if failures else 0


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.stderr.write(__doc__)
        sys.exit(2)
    if not os.path.isfile(sys.argv[1]) or not os.access(sys.argv[1], os.X_OK):
        print(f"FAIL  node not found ({sys.argv[1]!r}): the log cannot be read with @foxglove/ulog")
        sys.exit(1)
    sys.exit(main(*sys.argv[1:]))
