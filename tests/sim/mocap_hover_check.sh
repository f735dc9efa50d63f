#!/usr/bin/env bash
# The hover on a motion-capture feed (sim/scenarios/mocap_hover.yaml: no vision fix, the simulator's truth
# plus noise as an external-pose message on the radio, stamped with the mocap computer's own clock): the
# vehicle must take off, hold within 2 cm (horizontal std over the metrics window) and land on that feed
# alone (a vehicle that never takes off, for want of fixes, fails). Extra arguments go to quad_sim (--set ...: the estimator, the message).
#   mocap_hover_check.sh QUAD_SIM SCENARIO OUT_DIR [QUAD_SIM ARGS...]
set -euo pipefail
sim=$1 scenario=$2 out=$3
shift 3
rm -rf "$out"
"$sim" --scenario "$scenario" --out "$out" --no-plots --quiet "$@"
[ -s "$out/summary.json" ] || { echo "FAILED: $out/summary.json is missing"; exit 1; }
/usr/bin/python3 - "$out/summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
h = s["hold"]
std = h["horizontal"]["std_2d"]
print(f"complete {s['complete']}, crashed {s['crashed']}, external poses sent {s['external_poses_sent']}, "
      f"vision fixes sent {s['vision_fixes_sent']}; hold {h['start_s']}-{h['end_s']} s: horizontal std "
      f"{100 * std:.2f} cm, vertical std {100 * h['vertical']['std']:.2f} cm, mean |horizontal| "
      f"{100 * h['horizontal']['mean']:.2f} cm")
failures = []
if not s["complete"] or s["crashed"]: failures.append("the flight did not complete")
if s["vision_fixes_sent"] != 0: failures.append("vision fixes were sent: the feed must be alone")
if s["external_poses_sent"] < 25 * s["sim_time_s"]: failures.append("fewer external poses than 25 a second")
if h["samples"] < 100: failures.append("no hold window")
if s.get("altitude_reached_s") is None: failures.append("the vehicle never reached the setpoint's altitude")
if not abs(h["vertical"]["mean"]) <= 0.05: failures.append("the hold is not at the setpoint's height")
if not std <= 0.02: failures.append(f"horizontal std {std:.4f} m above 0.02 m")
if not h["horizontal"]["max"] <= 0.10: failures.append("the hold left a 10 cm band")
for f in failures: print("FAILED:", f)
sys.exit(1 if failures else 0)
PY
