#!/usr/bin/python3
"""ctests of tools/campaign (tests/campaign/CMakeLists.txt). Exit 77 (ctest: skipped) without Dask.

    test_campaign.py flight BUILD OUT    the short headline campaign; fails when a bound is not met
    test_campaign.py cluster BUILD OUT   a small campaign through a dask-scheduler and two dask-worker
                                         processes on 127.0.0.1: rows equal to a local run's (wall-clock
                                         columns excepted), every run flown by one of the two workers;
                                         flown again, every run is resumed; a bound not met exits 1
"""
import csv
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
TOOL = os.path.join(ROOT, "tools", "campaign")
SKIP = 77
WALL_CLOCK = {"wall_s", "resumed", "real_time_factor"}


def dask_or_skip():
    try:
        import distributed  # noqa: F401
    except ImportError:
        print("SKIPPED: python3-distributed (Dask) is not installed (tools/packages-debian.txt)")
        sys.exit(SKIP)
    for exe in ("dask-scheduler", "dask-worker"):
        if not shutil.which(exe):
            print(f"SKIPPED: {exe} is not on PATH (python3-distributed)")
            sys.exit(SKIP)


def campaign(build, out, *args):
    cmd = [TOOL, *args, "--build", build, "--out", out]
    print("+", " ".join(cmd), flush=True)
    return subprocess.run(cmd).returncode


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_cluster(log_dir):
    """dask-scheduler and two single-threaded dask-worker processes (no nanny: the pid is the worker)."""
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs = [subprocess.Popen(["dask-scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                              stdout=open(os.path.join(log_dir, "scheduler.log"), "w"), stderr=subprocess.STDOUT)]
    time.sleep(2)
    for i in range(2):
        procs.append(subprocess.Popen(["dask-worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                                       "--name", f"worker-{i}"],
                                      stdout=open(os.path.join(log_dir, f"worker-{i}.log"), "w"), stderr=subprocess.STDOUT))
    from distributed import Client
    with Client(address, timeout="30s") as c:
        c.wait_for_workers(2, timeout=60)
    return address, procs


def stop(procs):
    for p in reversed(procs):
        p.send_signal(signal.SIGINT)
    for p in procs:
        try:
            p.wait(timeout=15)
        except subprocess.TimeoutExpired:
            p.kill()


def without_wall_clock(rows):
    return [{k: v for k, v in r.items() if k not in WALL_CLOCK} for r in rows]


def cluster_test(build, out):
    small = os.path.join(HERE, "cluster_small.yaml")
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    failures = []
    address, procs = start_cluster(out)
    try:
        if campaign(build, os.path.join(out, "cluster"), small, "--scheduler", address, "--no-plots") != 0:
            failures.append("the campaign through the scheduler failed")
    finally:
        stop(procs)
    worker_pids = {p.pid for p in procs[1:]}
    if campaign(build, os.path.join(out, "local"), small, "--workers", "2", "--no-plots") != 0:
        failures.append("the local campaign failed")
    remote = read_rows(os.path.join(out, "cluster", "cluster_small", "runs.csv"))
    local = read_rows(os.path.join(out, "local", "cluster_small", "runs.csv"))
    if len(local) != 8:
        failures.append(f"{len(local)} rows, expected 2 seeds x 4 sweep points = 8")
    if without_wall_clock(remote) != without_wall_clock(local):
        for a, b in zip(without_wall_clock(remote), without_wall_clock(local)):
            if a != b:
                failures.append(f"rows differ:\n  cluster {a}\n  local   {b}")
    for row in remote:
        with open(os.path.join(out, "cluster", "cluster_small", "runs", row["run"], "campaign_run.json")) as f:
            pid = json.load(f)["worker_pid"]
        if pid not in worker_pids:
            failures.append(f"{row['run']} was flown by pid {pid}, not by one of the dask-worker processes {worker_pids}")
    # Flown again: nothing is flown, every row resumed and equal.
    if campaign(build, os.path.join(out, "local"), small, "--workers", "1", "--no-plots") != 0:
        failures.append("the resumed campaign failed")
    again = read_rows(os.path.join(out, "local", "cluster_small", "runs.csv"))
    if any(r["resumed"] != "yes" for r in again) or without_wall_clock(again) != without_wall_clock(local):
        failures.append("flown again, the runs were not all resumed with the same rows")
    # A bound not met exits 1: the same runs against a horizontal std median of at most 1 micrometre.
    strict = os.path.join(out, "strict.yaml")
    with open(small) as f, open(strict, "w") as g:
        g.write(f.read().replace("bounds: {median: 20.0}", "bounds: {median: 0.001}"))
    status = campaign(build, os.path.join(out, "local"), strict, "--workers", "1", "--no-plots", "--seeds", "3")
    if status != 1:
        failures.append(f"a campaign whose bound is not met exited {status}, not 1")
    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


def main():
    if len(sys.argv) != 4 or sys.argv[1] not in ("flight", "cluster"):
        sys.exit(__doc__)
    mode, build, out = sys.argv[1:]
    dask_or_skip()
    if mode == "flight":
        shutil.rmtree(out, ignore_errors=True)
        return campaign(build, out, os.path.join(HERE, "flight_short.yaml"), "--workers", "2")
    return cluster_test(build, out)


if __name__ == "__main__":
    sys.exit(main())
