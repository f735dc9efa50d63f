#!/usr/bin/env bash
# estimation_replay --filter ekf over a logged flight: quad_sim flies estimator_status.yaml for 30 s with
# the flight log from boot (LOG_MODE 2), then the replay runs the EKF beside the thesis pair and the
# baselines over the run folder's .ulg (--compare) against the run's truth (log.csv): every filter
# prints its figures, and the EKF's are within bounds (tilt RMS < 0.5 deg, horizontal RMS < 20 mm over
# the hold from 9 s).
#   replay_ekf_check.sh QUAD_SIM ESTIMATION_REPLAY SCENARIO OUT_DIR
set -euo pipefail
sim=$1 replay=$2 scenario=$3 out=$4
rm -rf "$out"
"$sim" --scenario "$scenario" --out "$out" --no-plots --quiet --set firmware_params.LOG_MODE=2 --set duration_s=30
[ -s "$out/log_001.ulg" ] || { echo "FAILED: $out/log_001.ulg is missing or empty"; exit 1; }
"$replay" --compare --calibrate 1.5 --mag-ref 0.20,-0.02,0.45 --truth "$out/log.csv" --from 9 \
  -o "$out/ekf_replay.csv" --filter ekf "$out/log_001.ulg" 2> "$out/replay.txt"
cat "$out/replay.txt"
for name in "thesis pair" unconditioned mahony linear ekf; do
  grep -q "^$name " "$out/replay.txt" || { echo "FAILED: no figures for '$name'"; exit 1; }
done
rows=$(($(wc -l < "$out/ekf_replay.csv") - 1))
[ "$rows" -gt 2500 ] || { echo "FAILED: $rows rows replayed by the EKF"; exit 1; }
line=$(grep "^ekf " "$out/replay.txt")
tilt=$(echo "$line" | sed -n 's/.*tilt RMS \([0-9.]*\) deg.*/\1/p')
horizontal=$(echo "$line" | sed -n 's/.*horizontal RMS \([0-9.]*\) mm.*/\1/p')
awk -v t="$tilt" -v h="$horizontal" 'BEGIN { exit !(t != "" && h != "" && t < 0.5 && h < 20.0) }' ||
  { echo "FAILED: the EKF's replay: tilt RMS '$tilt' deg (< 0.5), horizontal RMS '$horizontal' mm (< 20)"; exit 1; }
echo "replay --filter ekf: $rows rows, tilt RMS $tilt deg, horizontal RMS $horizontal mm"
