#!/usr/bin/env bash
# Flies tests/ulog/flight.yaml with quad_sim and the host firmware into OUT (the log tests' fixture):
# OUT/run holds log.csv, summary.json and the firmware's log_001.ulg.
#   fly.sh QUAD_SIM OUT
set -euo pipefail
sim="$1" out="$2"
rm -rf "$out"
mkdir -p "$out"
"$sim" --scenario "$(dirname "$0")/flight.yaml" --out "$out/run" --quiet --no-plots 2> "$out/stderr.txt" || {
  cat "$out/stderr.txt" >&2
  exit 1
}
if [ ! -s "$out/run/log_001.ulg" ]; then
  echo "fly.sh: the flight left no log_001.ulg in $out/run (does the firmware write its flight log?)" >&2
  ls "$out/run" >&2
  exit 1
fi
echo "fly.sh: $out/run/log_001.ulg ($(stat -c %s "$out/run/log_001.ulg") bytes)"
