"""A campaign file (sim/campaigns/*.yaml, format in docs/campaigns.md), checked and expanded into runs.

Every error names the file and the key; a run is a plain dict so Dask can ship it to any worker.
"""
import hashlib
import itertools
import os

import yaml

TOP_KEYS = {"name", "description", "doc", "scenarios", "groups", "seeds", "set", "sweep", "firmware", "command",
            "seed_env", "env", "success_output", "requires", "timeout_s", "figures", "crashed", "failed"}
GROUP_KEYS = {"name", "scenario", "vars", "set", "firmware", "crashed", "failed"}
FIGURE_KEYS = {"name", "label", "unit", "scale", "summary", "norm", "output", "file", "regex", "derived", "better",
               "wall_clock", "bounds", "anchors", "groups", "format", "sum"}
BOUND_KEYS = {"median", "p95", "worst"}
# Figures computed from a run's log (tools/campaigns/run.py): the altitude settling time, and the estimate
# at the n-th take-off and on the ground after the n-th landing (sim/plots/ground_figures.py), in metres.
GROUND_TAKEOFF = ("ground_height_error", "liftoff_jump")
GROUND_LANDING = ("ground_move", "ground_move_from_touchdown", "ground_error")
DERIVED = {"altitude_settled_s"} | {f"{k}_{n}" for k in GROUND_TAKEOFF + GROUND_LANDING for n in (1, 2, 3)}


class CampaignError(Exception):
    pass


def _fail(path, key, what):
    raise CampaignError(f"{path}: '{key}' {what}")


def _check_keys(path, where, mapping, allowed):
    if not isinstance(mapping, dict):
        _fail(path, where, "must be a mapping")
    for k in mapping:
        if k not in allowed:
            _fail(path, f"{where}.{k}" if where else k, f"is not a known key (expected one of: {', '.join(sorted(allowed))})")


def _seeds(path, value):
    if isinstance(value, list) and value and all(isinstance(s, int) and s >= 0 for s in value):
        return value
    if isinstance(value, dict) and set(value) == {"first", "count"} and all(isinstance(v, int) for v in value.values()):
        if value["count"] < 1 or value["first"] < 0:
            _fail(path, "seeds", "needs first >= 0 and count >= 1")
        return list(range(value["first"], value["first"] + value["count"]))
    _fail(path, "seeds", "must be a list of non-negative integers or {first: N, count: M}")


def _fraction_bound(path, where, value):
    if value is None:
        return None
    _check_keys(path, where, value, {"max_fraction"})
    f = value.get("max_fraction")
    if not isinstance(f, (int, float)) or not 0 <= f <= 1:
        _fail(path, f"{where}.max_fraction", "must be a number in [0, 1]")
    return float(f)


def _figure(path, i, f):
    where = f"figures[{i}]"
    _check_keys(path, where, f, FIGURE_KEYS)
    if not isinstance(f.get("name"), str) or not f["name"].isidentifier():
        _fail(path, f"{where}.name", "must be a name of letters, digits and underscores")
    sources = [k for k in ("summary", "norm", "output", "file", "derived") if k in f]
    if len(sources) != 1:
        _fail(path, where, "needs exactly one of summary, norm, output, file + regex, derived")
    if "file" in f and "regex" not in f:
        _fail(path, f"{where}.file", "needs a regex")
    if "norm" in f and not (isinstance(f["norm"], list) and all(isinstance(p, str) for p in f["norm"])):
        _fail(path, f"{where}.norm", "must be a list of summary.json paths")
    if "derived" in f and f["derived"] not in DERIVED:
        _fail(path, f"{where}.derived", f"must be one of {', '.join(sorted(DERIVED))}")
    if f.get("better", "lower") not in ("lower", "higher"):
        _fail(path, f"{where}.better", "must be lower or higher")
    bounds = f.get("bounds") or {}
    _check_keys(path, f"{where}.bounds", bounds, BOUND_KEYS)
    for k, v in bounds.items():
        if not isinstance(v, (int, float)):
            _fail(path, f"{where}.bounds.{k}", "must be a number (in the figure's unit)")
    anchors = f.get("anchors") or {}
    _check_keys(path, f"{where}.anchors", anchors, set(anchors))
    return {
        "name": f["name"], "label": f.get("label", f["name"]), "unit": f.get("unit", ""),
        "scale": float(f.get("scale", 1.0)), "summary": f.get("summary"), "norm": f.get("norm"),
        "output": f.get("output"), "file": f.get("file"), "regex": f.get("regex"), "derived": f.get("derived"),
        "better": f.get("better", "lower"), "wall_clock": bool(f.get("wall_clock", False)),
        "bounds": {k: float(v) for k, v in bounds.items()}, "anchors": {str(k): str(v) for k, v in anchors.items()},
        "groups": f.get("groups"), "format": f.get("format", ".2f"), "sum": bool(f.get("sum", False)),
    }


def file_sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()[:16]


def load(path, root):
    """The campaign at `path` (checked), paths resolved against the repository `root`."""
    try:
        with open(path) as f:
            c = yaml.safe_load(f)
    except OSError as e:
        raise CampaignError(f"{path}: cannot read ({e.strerror})")
    except yaml.YAMLError as e:
        raise CampaignError(f"{path}: YAML syntax: {e}")
    _check_keys(path, "", c, TOP_KEYS)
    for key in ("name", "seeds", "figures"):
        if key not in c:
            _fail(path, key, "is required")
    if ("scenarios" in c) == ("groups" in c):
        _fail(path, "scenarios", "give either scenarios (a list of files) or groups, not both")
    if "command" in c and not (isinstance(c["command"], list) and all(isinstance(a, str) for a in c["command"])):
        _fail(path, "command", "must be a list of arguments")
    env = c.get("env") or {}
    if not isinstance(env, dict) or not all(isinstance(v, (str, int, float)) for v in env.values()):
        _fail(path, "env", "must map environment variable names to values")
    if "seed_env" in c and "command" not in c:
        _fail(path, "seed_env", "goes with command")
    groups = []
    if "scenarios" in c:
        if not isinstance(c["scenarios"], list) or not c["scenarios"]:
            _fail(path, "scenarios", "must be a non-empty list of scenario files")
        groups = [{"name": os.path.splitext(os.path.basename(s))[0], "scenario": s} for s in c["scenarios"]]
    else:
        for i, g in enumerate(c["groups"] or []):
            _check_keys(path, f"groups[{i}]", g, GROUP_KEYS)
            if "name" not in g or ("scenario" not in g and "command" not in c):
                _fail(path, f"groups[{i}]", "needs name and scenario (a scenario is optional with command)")
            groups.append(g)
    names = [g["name"] for g in groups]
    if len(set(names)) != len(names):
        _fail(path, "groups", "has two groups of the same name")
    for g in groups:
        full = os.path.join(root, g.get("scenario", ""))
        if "scenario" in g and not os.path.isfile(full):
            _fail(path, f"{g['name']}.scenario", f"names {g['scenario']}, which does not exist")
    sweep = c.get("sweep") or {}
    if not isinstance(sweep, dict) or not all(isinstance(v, list) and v for v in sweep.values()):
        _fail(path, "sweep", "must map scenario keys to non-empty lists of values")
    figures = [_figure(path, i, f) for i, f in enumerate(c["figures"])]
    if len({f["name"] for f in figures}) != len(figures):
        _fail(path, "figures", "has two figures of the same name")
    timeout = c.get("timeout_s", 1800)
    if not isinstance(timeout, (int, float)) or timeout <= 0:
        _fail(path, "timeout_s", "must be a positive number of seconds")
    return {
        "path": path, "name": c["name"], "description": c.get("description", ""), "doc": c.get("doc"),
        "groups": groups, "seeds": _seeds(path, c["seeds"]), "set": c.get("set") or {}, "sweep": sweep,
        "firmware": c.get("firmware"), "command": c.get("command"), "seed_env": c.get("seed_env"),
        "env": {str(k): str(v) for k, v in env.items()}, "success_output": c.get("success_output"), "requires": c.get("requires") or [], "timeout_s": float(timeout), "figures": figures,
        "crashed": _fraction_bound(path, "crashed", c.get("crashed")),
        "failed": _fraction_bound(path, "failed", c.get("failed", {"max_fraction": 0.0})),
    }


def yaml_value(v):
    """A value as quad_sim --set takes it (YAML flow style, one line)."""
    return yaml.safe_dump(v, default_flow_style=True, width=1 << 20).strip().removesuffix("\n...").strip()


def sweep_points(campaign):
    keys = list(campaign["sweep"])
    for values in itertools.product(*(campaign["sweep"][k] for k in keys)):
        yield dict(zip(keys, values))


def group_id(group, point):
    if not point:
        return group["name"]
    return group["name"] + "+" + ",".join(f"{k}={yaml_value(v)}" for k, v in point.items())


def scenario_firmware_params(scenario_path, overrides):
    """The firmware parameters the run gets: the scenario's `firmware_params` with the overrides applied."""
    with open(scenario_path) as f:
        params = dict((yaml.safe_load(f) or {}).get("firmware_params") or {})
    for key, value in overrides.items():
        if key.startswith("firmware_params."):
            params[key.split(".", 1)[1]] = value
    return params


def expand(campaign, root, out_dir, template_vars):
    """Every run of the campaign, in a stable order: groups, sweep points, seeds."""
    runs = []
    for group in campaign["groups"]:
        scenario = os.path.join(root, group["scenario"]) if "scenario" in group else ""
        sha = file_sha256(scenario) if scenario else ""
        for point in sweep_points(campaign):
            overrides = {**campaign["set"], **(group.get("set") or {}), **point}
            gid = group_id(group, point)
            for seed in campaign["seeds"]:
                rel = os.path.join(gid.replace("/", "_"), f"seed-{seed}")
                run_dir = os.path.join(out_dir, "runs", rel)
                values = {**template_vars, **(group.get("vars") or {}), "seed": seed, "out": run_dir,
                          "scenario": scenario, "root": root}
                runs.append({
                    "campaign": campaign["name"], "group": gid, "seed": seed, "run": rel, "dir": run_dir,
                    "scenario": group.get("scenario", ""), "scenario_path": scenario, "scenario_sha256": sha,
                    "overrides": {k: yaml_value(v) for k, v in overrides.items()},
                    "firmware_params": scenario_firmware_params(scenario, overrides) if scenario else {},
                    "argv": _argv(campaign, group, values, scenario, seed, run_dir, overrides),
                    "env": {**{k: v.format_map(values) for k, v in campaign["env"].items()},
                            **({campaign["seed_env"]: str(seed)} if campaign.get("seed_env") else {})},
                    "timeout_s": campaign["timeout_s"], "figures": campaign["figures"],
                    "quad_sim": campaign["command"] is None, "root": root,
                    "success_output": campaign["success_output"],
                })
    return runs


def _argv(campaign, group, values, scenario, seed, run_dir, overrides):
    fill = lambda s: s.format_map(values)
    if campaign["command"] is not None:
        return [fill(a) for a in campaign["command"]]
    argv = [os.path.join(values["build"], "bin", "quad_sim"), "--scenario", scenario, "--out", run_dir,
            "--seed", str(seed), "--no-plots", "--quiet"]
    for k, v in overrides.items():
        argv += ["--set", f"{k}={yaml_value(v)}"]
    firmware = group.get("firmware", campaign["firmware"])
    if firmware:
        argv += ["--firmware", fill(firmware)]
    return argv
