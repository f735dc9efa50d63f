"""Runs a campaign's runs on a Dask cluster: a local one (one single-threaded worker process per core) or
an existing scheduler whose workers see the same build at the same paths. Shows a progress line.
"""
import os
import sys
import time

from . import run as run_module


def client_for(scheduler, workers):
    import cloudpickle
    from distributed import Client, LocalCluster

    # The task functions travel by value, so a cluster's workers need the build, not this tool's code.
    cloudpickle.register_pickle_by_value(run_module)
    if scheduler:
        client = Client(scheduler, timeout="30s")
        try:
            client.wait_for_workers(1, timeout=120)
        except Exception:  # TimeoutError of asyncio or distributed, by version
            client.close()
            raise RuntimeError(f"the scheduler {scheduler} has had no worker for 120 s (start dask-worker)")
        return client, None
    cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                           dashboard_address=":0", silence_logs=40)
    return Client(cluster), cluster


def _clock(seconds):
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}" if seconds >= 3600 else \
        f"{seconds // 60}:{seconds % 60:02d}"


class Progress:
    """`[name] 12/20 runs, 1 failed, 3 resumed, 2:10 elapsed, about 1:05 left` on one line (stderr)."""

    def __init__(self, name, total, resumed, failed):
        self.name, self.total, self.done, self.resumed, self.failed = name, total, resumed, resumed, failed
        self.start = time.monotonic()
        self.tty = sys.stderr.isatty()
        self.show()

    def add(self, ok):
        self.done += 1
        self.failed += 0 if ok else 1
        self.show()

    def show(self):
        elapsed = time.monotonic() - self.start
        flown = self.done - self.resumed
        left = self.total - self.done
        eta = f", about {_clock(elapsed / flown * left)} left" if flown and left else ""
        width = 24
        filled = width * self.done // max(1, self.total)
        line = (f"[{self.name}] [{'#' * filled}{'.' * (width - filled)}] {self.done}/{self.total} runs, "
                f"{self.failed} failed, {self.resumed} resumed, {_clock(elapsed)} elapsed{eta}")
        if self.tty:
            sys.stderr.write("\r" + line + ("\n" if not left else ""))
        elif not left or flown == 0 or self.done % max(1, self.total // 10) == 0:
            sys.stderr.write(line + "\n")
        sys.stderr.flush()


def fly_all(client, name, runs, commit, build):
    """Records of every run, in the runs' order: stored ones reused, the rest flown on the cluster."""
    from distributed import as_completed

    records = [run_module.stored(r, build) for r in runs]
    for rec in records:
        if rec is not None:
            rec["resumed"] = True
    todo = [i for i, rec in enumerate(records) if rec is None]
    progress = Progress(name, len(runs), len(runs) - len(todo),
                        sum(1 for rec in records if rec is not None and not rec["ok"]))
    if not todo:
        return records
    # pure=False: two runs are never the same task, even with equal arguments.
    futures = {client.submit(run_module.fly, runs[i], commit, build, pure=False, key=f"{name}-{runs[i]['run']}-{time.time_ns()}"): i
               for i in todo}
    for future in as_completed(futures):
        i = futures[future]
        try:
            records[i] = future.result()
        except Exception as e:  # the worker died or could not start the run: a failed run, not a dead campaign
            records[i] = {"exit_status": f"worker error: {e}", "commit": commit, "wall_s": 0.0, "ok": False, "crashed": False,
                          "figures": {}, "failure": str(e)}
        records[i]["resumed"] = False
        progress.add(records[i]["ok"])
    return records
