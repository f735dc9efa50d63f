"""One run of a campaign, on whichever worker Dask gives it: fly it in its own folder, read its figures.

The run folder gets output.txt (the process' stdout and stderr) and campaign_run.json (exit status, wall
time, the commit, and what identifies the run: the hashes of the executables and images it ran, the
scenario's hash, its arguments), which is how a campaign started again knows this run is done: a
commit that changes only docs or tools keeps the runs, a rebuilt firmware flies them again.
"""
import hashlib
import importlib.util
import json
import math
import os
import re
import subprocess
import time

RECORD = "campaign_run.json"


_hashes = {}


def _file_hash(path):
    if path not in _hashes:
        with open(path, "rb") as f:
            _hashes[path] = hashlib.sha256(f.read()).hexdigest()[:16]
    return _hashes[path]


def executables(run, build):
    """The files a run executes or loads: the host executables and every existing file its arguments name."""
    files = {os.path.join(build, "bin", exe) for exe in ("quad_sim", "quad_firmware", "vision_station")}
    for arg in run["argv"]:
        for word in arg.split():
            if os.path.isfile(word) and os.access(word, os.R_OK) and not word.endswith((".yaml", ".txt")):
                files.add(word)
    return {f: _file_hash(f) for f in sorted(files) if os.path.isfile(f)}


def identity(run, build):
    """What must match for a stored run to stand for this one."""
    return {"executables": executables(run, build), "scenario_sha256": run["scenario_sha256"],
            "overrides": run["overrides"], "argv": run["argv"], "env": run["env"]}


def stored(run, build):
    """The record of an identical finished run in the run's folder, its figures read again (the campaign's
    figures may have changed since); None when there is none (a quad_sim run needs a complete summary)."""
    try:
        with open(os.path.join(run["dir"], RECORD)) as f:
            record = json.load(f)
        with open(os.path.join(run["dir"], "output.txt"), errors="replace") as f:
            output = f.read()
    except (OSError, ValueError):
        return None
    if record.get("identity") != identity(run, build):
        return None
    if run["quad_sim"]:
        summary = _summary(run["dir"])
        if not summary or not summary.get("complete"):
            return None
    record.update(read_outcome(run, output, record["exit_status"]))
    return record


def _summary(run_dir):
    try:
        with open(os.path.join(run_dir, "summary.json")) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def _path(summary, dotted):
    node = summary
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node if isinstance(node, (int, float)) and not isinstance(node, bool) else None


def _search(regex, text, total=False):
    """The first match's number (its first group, else the match), or with total the sum over all matches."""
    try:
        values = [float(m.group(1) if m.groups() else m.group(0)) for m in re.finditer(regex, text, re.MULTILINE)]
    except ValueError:
        return None
    if not values:
        return None
    return sum(values) if total else values[0]


def _altitude_settled_s(run):
    """Seconds from the climb command until the altitude stays within 5 cm (sim/plots/flight_report.py)."""
    spec = importlib.util.spec_from_file_location(
        "flight_report", os.path.join(run["root"], "sim", "plots", "flight_report.py"))
    report = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(report)
    summary = _summary(run["dir"]) or {}
    command_t = report.climb_command_time(os.path.join(run["dir"], "events.log"))
    if command_t is None or "hold" not in summary:
        return None
    return report.altitude_settled_after_until(os.path.join(run["dir"], "log.csv"), command_t,
                                               summary["hold"]["end_s"])


def _ground_figure(run, name):
    """A figure of sim/plots/ground_figures.py: NAME_N for the N-th take-off or landing, in metres."""
    spec = importlib.util.spec_from_file_location(
        "ground_figures", os.path.join(run["root"], "sim", "plots", "ground_figures.py"))
    figures = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(figures)
    kind, n = name.rsplit("_", 1)
    n = int(n)
    try:
        log = figures.read_log(run["dir"])
    except (OSError, KeyError, ValueError):
        return None
    if kind in ("ground_height_error", "liftoff_jump"):
        rows = figures.take_offs(log)
        if len(rows) < n:
            return None
        return rows[n - 1][1] if kind == "ground_height_error" else rows[n - 1][2]
    rows = figures.landings(log)
    if len(rows) < n:
        return None
    return {"ground_move": rows[n - 1]["move_m"], "ground_move_from_touchdown": rows[n - 1]["move_from_touchdown_m"],
            "ground_error": rows[n - 1]["error_m"]}[kind]


def figure_value(run, figure, summary, output):
    """One figure of a finished run, in the figure's unit; None when the run does not give it."""
    if figure["groups"] and run["group"].split("+")[0] not in figure["groups"]:
        return None
    if figure["summary"]:
        v = _path(summary or {}, figure["summary"])
    elif figure["norm"]:
        parts = [_path(summary or {}, p) for p in figure["norm"]]
        v = None if any(p is None for p in parts) else math.sqrt(sum(p * p for p in parts))
    elif figure["output"]:
        v = _search(figure["output"], output, figure["sum"])
    elif figure["file"]:
        try:
            with open(os.path.join(run["dir"], figure["file"]), errors="replace") as f:
                v = _search(figure["regex"], f.read(), figure["sum"])
        except OSError:
            v = None
    elif figure["derived"] == "altitude_settled_s":
        v = _altitude_settled_s(run)
    else:
        v = _ground_figure(run, figure["derived"])
    return None if v is None or v != v else v * figure["scale"]


def fly(run, commit, build):
    """Flies one run (a Dask task): returns its record, also written to the run folder."""
    os.makedirs(run["dir"], exist_ok=True)
    for stale in (RECORD, "summary.json"):
        if os.path.exists(os.path.join(run["dir"], stale)):
            os.remove(os.path.join(run["dir"], stale))
    start = time.monotonic()
    env = {**os.environ, **run["env"]}
    try:
        p = subprocess.run(run["argv"], cwd=run["root"], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           timeout=run["timeout_s"])
        status, output = p.returncode, p.stdout.decode(errors="replace")
    except subprocess.TimeoutExpired as e:
        status, output = "timeout", (e.stdout or b"").decode(errors="replace")
    except OSError as e:
        status, output = "not started", str(e)
    wall = time.monotonic() - start
    with open(os.path.join(run["dir"], "output.txt"), "w") as f:
        f.write(output)
    record = {"identity": identity(run, build), "commit": commit, "exit_status": status, "wall_s": round(wall, 2),
              "worker_pid": os.getpid()}
    record.update(read_outcome(run, output, status))
    with open(os.path.join(run["dir"], RECORD), "w") as f:
        json.dump(record, f, indent=1)
    return record


def read_outcome(run, output, status):
    """ok / crashed / the figures of a finished run (worker side, so a cluster needs no shared folder)."""
    summary = _summary(run["dir"]) if run["quad_sim"] else None
    if run["quad_sim"]:
        # quad_sim: 0 complete, 3 complete but the plots failed (not asked for here); anything else failed.
        ok = status in (0, 3) and bool(summary and summary.get("complete"))
        crashed = bool(summary and summary.get("crashed"))
    else:
        ok, crashed = status == 0, False
    if run["success_output"] and not re.search(run["success_output"], output, re.MULTILINE):
        ok = False  # e.g. a test filter that matched nothing exits 0 too
    figures = {f["name"]: figure_value(run, f, summary, output) for f in run["figures"]}
    return {"ok": ok, "crashed": crashed, "figures": figures, "failure": "" if ok else _excerpt(output)}


def _excerpt(output):
    """The lines that say why a run failed: from the first failure or error message, else the last ones."""
    lines = output.strip().splitlines()
    first = next((i for i, line in enumerate(lines) if re.search(r"Failure|error|cut short|CRASHED", line)), None)
    return "\n".join(lines[first:first + 6] if first is not None else lines[-6:])
