#!/usr/bin/env python3
"""Scores `vision_station detect` output against the truth written by vision_eval_gen.

    vision_eval.py score --sets DIR --runs NAME=DETECT_DIR [NAME=DETECT_DIR ...] [--markdown OUT.md]
    vision_eval.py insert --doc FILE --marker NAME --command "CMD" --from TEXT_FILE [--tables-only]

insert replaces the text between `<!-- NAME:begin -->` and `<!-- NAME:end -->` in FILE by TEXT_FILE's
content (with --tables-only: its markdown table lines), headed by the command, the commit and the date.

DIR/<condition>/truth.csv is the truth; DETECT_DIR/<condition>.jsonl holds one `detect` JSON line per pair
(in pairs.csv order). A fix counts as the star when its 3-D error is within 5 % of the range; any other fix
(on a pair without a star in full view, or far from the star) is a false fix. Prints a table per run and
condition, and one per factor (floor, blur, interlacing, JPEG quality, range, tilt) over all conditions.
"""
import argparse
import csv
import json
import math
import os
import datetime
import statistics
import subprocess
import sys

MATCH_FRACTION = 0.05


def percentile(values, q):
    if not values:
        return float("nan")
    s = sorted(values)
    k = (len(s) - 1) * q
    lo, hi = math.floor(k), math.ceil(k)
    return s[lo] + (s[hi] - s[lo]) * (k - lo)


def load(sets_dir, detect_dir, condition):
    truth_path = os.path.join(sets_dir, condition, "truth.csv")
    detect_path = os.path.join(detect_dir, condition + ".jsonl")
    with open(truth_path) as f:
        truth = list(csv.DictReader(f))
    with open(detect_path) as f:
        fixes = [json.loads(line) for line in f if line.strip()]
    if len(fixes) != len(truth):
        sys.exit(f"{detect_path}: {len(fixes)} lines for {len(truth)} pairs in {truth_path}")
    rows = []
    for t, d in zip(truth, fixes):
        row = {k: t[k] for k in t}
        row["condition"] = condition
        row["in_view"] = t["star_in_view"] == "1"
        row["found"] = bool(d.get("found"))
        row["ms"] = d.get("ms")
        row["error"] = None
        row["tilt_error"] = None
        row["tilt_predicted"] = None
        row["has_pose"] = d.get("q") is not None
        if row["found"] and row["in_view"]:
            err = math.dist((d["x"], d["y"], d["z"]), (float(t["x"]), float(t["y"]), float(t["z"])))
            row["error"] = err / float(t["range_m"])
            row["tilt_error"] = tilt_error(t, d)
            row["tilt_predicted"] = tilt_predicted(d)
        rows.append(row)
    return rows


def tilt_error(truth, fix):
    """Angle (degrees) between the star's fitted normal and the floor's true normal, both in the left
    camera frame; None without a pose or without the truth's normal (sets from older generators)."""
    n = fix.get("normal_camera")
    if not n or not truth.get("normal_x"):
        return None
    t = (float(truth["normal_x"]), float(truth["normal_y"]), float(truth["normal_z"]))
    dot = sum(a * b for a, b in zip(n, t)) / (math.hypot(*n) * math.hypot(*t))
    return math.degrees(math.acos(max(-1.0, min(1.0, dot))))


def tilt_predicted(fix):
    """The median tilt error (degrees) the pose fit's own covariance predicts: its roll and pitch σ come
    from the residual of the edge points (σ̂² (JᵀJ)⁻¹), and the median length of a 2-D normal error with
    per-axis σ is σ·√(2 ln 2) (the RMS of the two σ for unequal ones)."""
    s = fix.get("attitude_sigma_rad")
    if not s or fix.get("normal_camera") is None:
        return None
    return math.degrees(math.sqrt(2.0 * math.log(2.0)) * math.sqrt((s[0] ** 2 + s[1] ** 2) / 2.0))


TILT_HEADER = ("| range | stars found | with a pose | median tilt error | p95 tilt error | median predicted by the fit |\n"
               "| --- | ---: | ---: | ---: | ---: | ---: |")


def tilt_report(name, rows):
    """The star pose's tilt error per range over the found stars (the fix within 5 % of the range)."""
    key = FACTORS[4][1]
    hits = [r for r in rows if r["error"] is not None and r["error"] <= MATCH_FRACTION]
    if not any(r["tilt_error"] is not None for r in hits):
        return []
    out = [f"#### {name}: tilt of the star pose (found stars)", "", TILT_HEADER]
    for level in sorted({key(r) for r in hits}) + ["all"]:
        group = [r for r in hits if level == "all" or key(r) == level]
        tilts = [r["tilt_error"] for r in group if r["tilt_error"] is not None]
        median = statistics.median(tilts) if tilts else float("nan")
        predicted = [r["tilt_predicted"] for r in group if r["tilt_predicted"] is not None]
        expected = statistics.median(predicted) if predicted else float("nan")
        out.append(f"| {level} | {len(group)} | {len(tilts)} | {median:.3f}° | {percentile(tilts, 0.95):.3f}° |"
                   f" {expected:.3f}° |")
    return out + [""]


def summarise(rows):
    stars = [r for r in rows if r["in_view"]]
    hits = [r for r in stars if r["error"] is not None and r["error"] <= MATCH_FRACTION]
    false_fixes = sum(1 for r in rows if r["found"] and not (r["error"] is not None and r["error"] <= MATCH_FRACTION))
    errors = [100.0 * r["error"] for r in hits]
    ms = [r["ms"] for r in rows if r["ms"] is not None]
    return {
        "pairs": len(rows), "stars": len(stars), "found": len(hits), "false": false_fixes,
        "rate": 100.0 * len(hits) / len(stars) if stars else float("nan"),
        "median": statistics.median(errors) if errors else float("nan"),
        "p95": percentile(errors, 0.95), "ms": statistics.median(ms) if ms else float("nan"),
    }


HEADER = ("| {k} | pairs | stars in view | found | rate | false fixes | median error | p95 error | median ms |\n"
          "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")


def line(label, s):
    return (f"| {label} | {s['pairs']} | {s['stars']} | {s['found']} | {s['rate']:.2f} % | {s['false']} | "
            f"{s['median']:.3f} % | {s['p95']:.3f} % | {s['ms']:.2f} |")


def bins(value, edges, unit):
    if value < edges[0]:
        return f"< {edges[0]:g}{unit}"
    for lo, hi in zip(edges, edges[1:]):
        if lo <= value < hi:
            return f"{lo:g}–{hi:g}{unit}"
    return f"≥ {edges[-1]:g}{unit}"


FACTORS = [
    ("floor", lambda r: r["floor"]),
    ("motion blur", lambda r: bins(float(r["blur_px"]), [0, 2, 4, 6.01], " px")),
    ("interlaced", lambda r: "yes" if r["interlaced"] == "1" else "no"),
    ("JPEG quality", lambda r: "lossless" if r["jpeg_quality"] == "0" else bins(int(r["jpeg_quality"]), [50, 70, 91], "")),
    ("range", lambda r: bins(float(r["range_m"]), [0.5, 1, 1.5, 2, 2.5], " m") if r["in_view"] else "no star in view"),
    ("tilt", lambda r: bins(float(r["tilt_deg"]), [0, 5, 10, 15, 20.01], "°")),
]


def false_fix_report(name, rows):
    """What each false fix was: the star in full view placed more than 5 % of its range off (its error,
    and whether the fix had a pose), or a fix on a pair without a star in full view (a decoy, a star cut
    by the image edge, or nothing)."""
    wrong = [r for r in rows if r["found"] and not (r["error"] is not None and r["error"] <= MATCH_FRACTION)]
    if not wrong:
        return []
    out = [f"#### {name}: false fixes", "",
           "| condition | pair | star in full view | its error | a star cut by the edge too | fix with a pose |",
           "| --- | --- | --- | ---: | --- | --- |"]
    yes_no = lambda b: "yes" if b else "no"
    for r in wrong:
        error = f"{100.0 * r['error']:.1f} %" if r["in_view"] else "—"
        out.append(f"| {r['condition']} | {r['left']} | {yes_no(r['in_view'])} | {error} | "
                   f"{yes_no(r.get('star_cut') == '1')} | {yes_no(r['has_pose'])} |")
    return out + [""]


def report(name, rows, conditions):
    out = [f"#### {name}: per condition", "", HEADER.format(k="condition")]
    for c in conditions:
        out.append(line(c, summarise([r for r in rows if r["condition"] == c])))
    out.append(line("all", summarise(rows)))
    out += [""] + false_fix_report(name, rows)
    out += [f"#### {name}: per factor (all conditions; pairs without a star count under their own level)", ""]
    for factor, key in FACTORS:
        out.append(HEADER.format(k=factor))
        levels = sorted({key(r) for r in rows})
        for level in levels:
            out.append(line(level, summarise([r for r in rows if key(r) == level])))
        out.append("")
    out += tilt_report(name, rows)
    return "\n".join(out)


def insert(doc, marker, command, source, tables_only):
    with open(source) as f:
        lines = f.read().splitlines()
    if tables_only:
        lines = [l for l in lines if l.startswith("|")]
    if not lines:
        sys.exit(f"{source}: nothing to insert")
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=os.path.dirname(os.path.abspath(doc))).stdout.strip() or "unknown"
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    body = [f"<!-- {marker}:begin -->", f"Generated by `{command}` at commit {commit}, {stamp}.", ""] + lines + [
        f"<!-- {marker}:end -->"]
    with open(doc) as f:
        text = f.read()
    begin, end = f"<!-- {marker}:begin -->", f"<!-- {marker}:end -->"
    if begin not in text or end not in text:
        sys.exit(f"{doc}: markers {begin} ... {end} not found")
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    with open(doc, "w") as f:
        f.write(head + "\n".join(body) + tail)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    score = sub.add_parser("score")
    score.add_argument("--sets", required=True)
    score.add_argument("--runs", nargs="+", required=True, help="NAME=DETECT_DIR")
    score.add_argument("--conditions", default=None, help="comma list; default: every set directory")
    score.add_argument("--markdown", default=None)
    score.add_argument("--check", default=None, help="MIN_RATE,MAX_FALSE,MAX_MEDIAN for the first run, all conditions")
    ins = sub.add_parser("insert")
    ins.add_argument("--doc", required=True)
    ins.add_argument("--marker", required=True)
    ins.add_argument("--command", dest="cmd", required=True)
    ins.add_argument("--from", dest="source", required=True)
    ins.add_argument("--tables-only", action="store_true")
    args = parser.parse_args()
    if args.command == "insert":
        insert(args.doc, args.marker, args.cmd, args.source, args.tables_only)
        return
    conditions = args.conditions.split(",") if args.conditions else sorted(
        d for d in os.listdir(args.sets) if os.path.exists(os.path.join(args.sets, d, "truth.csv")))
    text = []
    first = None
    for run in args.runs:
        name, _, detect_dir = run.partition("=")
        rows = [r for c in conditions for r in load(args.sets, detect_dir, c)]
        first = first or summarise(rows)
        text.append(report(name, rows, conditions))
    result = "\n\n".join(text) + "\n"
    print(result)
    if args.markdown:
        with open(args.markdown, "w") as f:
            f.write(result)
    if args.check:
        min_rate, max_false, max_median = (float(v) for v in args.check.split(","))
        if first["stars"] == 0:
            sys.exit("check: no star in full view in the sets")
        failed = [what for what, bad in (
            (f"rate {first['rate']:.2f} % < {min_rate} %", first["rate"] < min_rate),
            (f"{first['false']} false fixes > {max_false:g}", first["false"] > max_false),
            (f"median error {first['median']:.3f} % > {max_median} %", not first["median"] <= max_median)) if bad]
        if failed:
            sys.exit("check failed: " + "; ".join(failed))
        print("check passed")


if __name__ == "__main__":
    main()
