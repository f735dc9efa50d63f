#!/usr/bin/python3
"""ctest campaign_files: every campaign file of sim/campaigns/ loads (tools/campaigns/spec.py, the checks
`tools/campaign` makes before it flies anything), and the doc each one names holds its generated
section's two markers, so that `make results` rewrites that section in place instead of appending one at
the doc's end. A file without its markers, made here, is reported: the check can fail.

    test_campaign_files.py
"""
import glob
import os
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "tools"))

from campaigns import docs, spec  # noqa: E402


def problems(path, root):
    """What is wrong with one campaign file (empty: nothing)."""
    try:
        c = spec.load(path, root)
    except spec.CampaignError as e:
        return [str(e)]
    if not c["doc"]:
        return []
    doc = os.path.join(root, c["doc"])
    if not os.path.isfile(doc):
        return [f"{path}: doc {c['doc']} does not exist"]
    with open(doc) as f:
        text = f.read()
    begin, end = docs._markers(c["name"])
    if not (begin.search(text) and end.search(text)):
        return [f"{path}: {c['doc']} has no generated section for campaign {c['name']} (its two markers)"]
    return []


def main():
    files = sorted(glob.glob(os.path.join(ROOT, "sim", "campaigns", "*.yaml")))
    if not files:
        print("no campaign files found")
        return 1
    found = [p for f in files for p in problems(f, ROOT)]
    for p in found:
        print(p)
    print(f"{len(files)} campaign files, {len(found)} problems")
    # The check itself: a campaign whose doc lacks its markers.
    with tempfile.TemporaryDirectory() as tmp:
        os.makedirs(os.path.join(tmp, "docs"))
        with open(os.path.join(tmp, "docs", "x.md"), "w") as f:
            f.write("# x\n")
        bad = os.path.join(tmp, "bad.yaml")
        with open(bad, "w") as f:
            f.write("name: bad\ndoc: docs/x.md\ncommand: [\"true\"]\nseeds: [1]\ngroups:\n  - {name: g}\n"
                    "figures:\n  - {name: f, output: 'x (\\\\d+)'}\n")
        if not problems(bad, tmp):
            print("a doc without the markers was not reported")
            return 1
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
