"""A campaign's outputs: runs.csv (a row per run), the aggregates checked against the bounds,
aggregates.md (the table beside the anchors' figures) and one plot per group (each figure over the seeds).
"""
import csv
import json
import os

from . import stats

# Columns that depend on the wall clock or on where the campaign ran, not on the flight.
WALL_CLOCK_COLUMNS = {"wall_s", "resumed"}


def rows(runs, records):
    out = []
    for run, rec in zip(runs, records):
        row = {
            "campaign": run["campaign"], "group": run["group"], "seed": run["seed"], "run": run["run"],
            "status": "ok" if rec["ok"] else f"failed ({rec['exit_status']})",
            "crashed": "yes" if rec["crashed"] else "no", "commit": rec.get("commit", ""), "scenario": run["scenario"],
            "scenario_sha256": run["scenario_sha256"],
            "overrides": " ".join(f"{k}={v}" for k, v in run["overrides"].items()),
            "firmware_params": " ".join(f"{k}={v}" for k, v in sorted(run["firmware_params"].items())),
        }
        for f in run["figures"]:
            v = rec["figures"].get(f["name"])
            row[f["name"]] = "" if v is None else f"{v:.9g}"
        row["wall_s"] = f"{rec['wall_s']:.2f}"
        row["resumed"] = "yes" if rec.get("resumed") else "no"
        out.append(row)
    return out


def write_csv(path, table):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(table[0]))
        w.writeheader()
        w.writerows(table)


def evaluate(campaign, runs, records):
    """Per group: the aggregates of every figure and each bound's verdict."""
    groups = {}
    for run, rec in zip(runs, records):
        groups.setdefault(run["group"], []).append((run, rec))
    result = []
    for gid, members in groups.items():
        base = next(g for g in campaign["groups"] if g["name"] == gid.split("+")[0])
        n = len(members)
        failed = sum(not rec["ok"] for _, rec in members)
        crashed = sum(rec["crashed"] for _, rec in members)
        checks = []
        for what, count, bound in (("failed", failed, _bound(campaign, base, "failed")),
                                   ("crashed", crashed, _bound(campaign, base, "crashed"))):
            if bound is not None:
                checks.append({"figure": f"fraction {what}", "aggregate": "fraction", "value": count / n,
                               "bound": bound, "ok": count / n <= bound + 1e-12})
        figures = []
        for f in campaign["figures"]:
            values = [rec["figures"][f["name"]] for _, rec in members if rec["figures"].get(f["name"]) is not None]
            agg = stats.aggregate(values, f["better"])
            figures.append({"figure": f, "agg": agg})
            applies = not f["groups"] or gid.split("+")[0] in f["groups"]
            for key, bound in f["bounds"].items():
                if not applies:
                    continue
                value = agg[key] if agg else None
                checks.append({"figure": f["name"], "aggregate": key, "value": value, "bound": bound,
                               "unit": f["unit"], "ok": value is not None and stats.within(value, bound, f["better"])})
        result.append({"group": gid, "n": n, "failed": failed, "crashed": crashed, "flights": members[0][0]["quad_sim"],
                       "failed_ci": stats.fraction_interval(failed, n), "crashed_ci": stats.fraction_interval(crashed, n),
                       "figures": figures, "checks": checks, "ok": all(c["ok"] for c in checks),
                       "seeds": sorted(run["seed"] for run, _ in members)})
    return result


def _bound(campaign, group, what):
    if what in group:
        return group[what]["max_fraction"] if group[what] else None
    return campaign[what]


def _num(v, fmt):
    return "—" if v is None else format(v, fmt).replace("-", "−")


def _ci(ci, fmt):
    lo, hi = ci
    return f"[{_num(lo, fmt)}, {_num(hi, fmt)}]"


def _seed_text(seeds):
    if seeds == list(range(seeds[0], seeds[0] + len(seeds))):
        return f"{seeds[0]}–{seeds[-1]}" if len(seeds) > 1 else str(seeds[0])
    return ", ".join(map(str, seeds))


def markdown(campaign, evaluation, plot_links):
    """The aggregates table of every group, its bounds' verdicts and the anchors' figures."""
    anchors = list(dict.fromkeys(a for f in campaign["figures"] for a in f["anchors"]))
    lines = []
    for g in evaluation:
        # A command run's crash is one of its failures (its own assertions); a flight's is in its summary.
        what, ci = ("crashed", g["crashed_ci"]) if g["flights"] else ("failed", g["failed_ci"])
        lines.append(f"**{g['group']}**: {g['n']} runs (seeds {_seed_text(g['seeds'])}); failed {g['failed']}"
                     + (f", crashed {g['crashed']}" if g["flights"] else "")
                     + f" (95 % interval of the {what} fraction {_ci(ci, '.2f')}).")
        lines.append("")
        head = ["figure", "median [95 % CI]", "p95 [95 % CI]", "worst", "bound", "verdict"] + anchors
        lines += ["| " + " | ".join(head) + " |", "| " + " | ".join(["---"] * len(head)) + " |"]
        for entry in g["figures"]:
            f, agg = entry["figure"], entry["agg"]
            if agg is None:
                continue
            fmt = f["format"]
            checks = [c for c in g["checks"] if c["figure"] == f["name"]]
            bound = ", ".join(f"{c['aggregate']} {'≤' if f['better'] == 'lower' else '≥'} {_num(c['bound'], fmt)}"
                              for c in checks) or "—"
            verdict = "—" if not checks else ("met" if all(c["ok"] for c in checks) else "**NOT MET**")
            p_label = "p95" if f["better"] == "lower" else "p5"
            cells = [f"{f['label']}{' (' + f['unit'] + ')' if f['unit'] else ''}".replace("|", "\\|"),
                     f"**{_num(agg['median'], fmt)}** {_ci(agg['median_ci'], fmt)}",
                     f"{p_label} {_num(agg['p95'], fmt)} {_ci(agg['p95_ci'], fmt)}",
                     _num(agg["worst"], fmt), bound, verdict] + [f["anchors"].get(a, "—") for a in anchors]
            lines.append("| " + " | ".join(cells) + " |")
        for c in g["checks"]:
            if c["aggregate"] == "fraction":
                lines.append(f"| {c['figure']} | {_num(c['value'], '.2f')} | | | ≤ {_num(c['bound'], '.2f')} | "
                             f"{'met' if c['ok'] else '**NOT MET**'} |" + " |" * len(anchors))
        lines.append("")
        if g["group"] in plot_links:
            lines += [f"![{campaign['name']}: {g['group']}, each figure over the seeds]({plot_links[g['group']]})", ""]
    return "\n".join(lines)


def plot(campaign, group_eval, path):
    """Each figure's value per seed (dots) with its median and bounds; one panel per figure."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [e for e in group_eval["figures"] if e["agg"] is not None and not e["figure"]["wall_clock"]]
    if not panels:
        return False
    cols = min(3, len(panels))
    nrows = (len(panels) + cols - 1) // cols
    fig, axes = plt.subplots(nrows, cols, figsize=(4.2 * cols, 2.6 * nrows), squeeze=False)
    for ax, e in zip(axes.flat, panels):
        f = e["figure"]
        values = e["values"]
        ax.hist(values, bins=min(20, max(5, len(values) // 2)), color="#4878a8", alpha=0.8)
        ax.axvline(e["agg"]["median"], color="k", lw=1.2, label="median")
        for key, bound in f["bounds"].items():
            ax.axvline(bound, color="#c03030", ls="--", lw=1, label=f"bound ({key})")
        ax.set_title(f["label"], fontsize=9)
        ax.set_xlabel(f["unit"] or "value", fontsize=8)
        ax.set_ylabel("runs", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=6)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    fig.suptitle(f"{campaign['name']}: {group_eval['group']}, {group_eval['n']} runs", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return True


def attach_values(evaluation, runs, records):
    for g in evaluation:
        for e in g["figures"]:
            name = e["figure"]["name"]
            e["values"] = [rec["figures"][name] for run, rec in zip(runs, records)
                           if run["group"] == g["group"] and rec["figures"].get(name) is not None]


def verdict_lines(campaign, evaluation):
    out = []
    for g in evaluation:
        for c in g["checks"]:
            if not c["ok"]:
                what = c["figure"] if c["aggregate"] == "fraction" else f"{c['figure']} {c['aggregate']}"
                out.append(f"campaign {campaign['name']}: {g['group']}: {what} = {_num(c['value'], '.4g')} "
                           f"{c.get('unit', '')}, bound {_num(c['bound'], '.4g')}: NOT MET")
    return out


def write_json(path, campaign, evaluation, commit, date):
    strip = [{**g, "figures": [{"figure": e["figure"]["name"], **(e["agg"] or {})} for e in g["figures"]]}
             for g in evaluation]
    with open(path, "w") as f:
        json.dump({"campaign": campaign["name"], "file": campaign["path"], "commit": commit, "date": date,
                   "groups": strip}, f, indent=1)


def out_paths(out_dir):
    return {k: os.path.join(out_dir, v) for k, v in
            {"csv": "runs.csv", "md": "aggregates.md", "json": "aggregates.json", "plots": "plots"}.items()}
