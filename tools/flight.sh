#!/usr/bin/env bash
# `make flight`: flies one scenario headless with the simulator, the host firmware and the
# vision station in the loop (default sim/scenarios/flight.yaml: take off, climb to 1.5 m above the star,
# hold 60 s, land), then prints this run's figures beside the thesis' and Oh et al.'s.
#   tools/flight.sh [SCENARIO] [--out DIR] [--video]      (the Makefile builds first)
#   FLIGHT_VIDEO=1 make flight                            also renders a chase-camera MP4 (slower)
# The run folder (default runs/<scenario>-<UTC time>) holds log.csv, events.log, summary.json, the PNG
# plots, firmware.log, station.log, report.txt and, with --video, flight.mp4. The station learns the
# cameras from chessboards the simulator renders (`vision_station calibrate`, cached in
# build/host/bin/station_calibration/ until the cameras or the station change; docs/simulator.md).
set -euo pipefail
cd "$(dirname "$0")/.."

scenario=sim/scenarios/flight.yaml
out=""
video="${FLIGHT_VIDEO:-0}"
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    --video) video=1; shift ;;
    -h|--help) sed -n '2,9p' "$0"; exit 0 ;;
    *) scenario="$1"; shift ;;
  esac
done
bin="${QUAD_BIN_DIR:-build/host/bin}"
for exe in quad_sim quad_firmware vision_station; do
  if [ ! -x "$bin/$exe" ]; then
    echo "flight: $bin/$exe is not built (make build)" >&2
    exit 1
  fi
done
if [ -z "$out" ]; then
  name=$(sed -n 's/^name: *//p' "$scenario" | head -n 1)
  out="runs/${name:-flight}-$(date -u +%Y%m%dT%H%M%SZ)"
fi
mkdir -p "$out"
record=()
if [ "$video" = 1 ]; then
  command -v ffmpeg >/dev/null || { echo "flight: --video needs ffmpeg" >&2; exit 1; }
  record=(--record "$out/flight.mp4")
fi

echo "flight: $scenario -> $out (simulator, firmware and vision station in lockstep; progress below)"
status=0
"$bin/quad_sim" --scenario "$scenario" --out "$out" "${record[@]}" || status=$?
echo
python3 sim/plots/flight_report.py "$out" || status=1
echo
echo "flight: run folder $out (log.csv, summary.json, report.txt, *.png${record:+, flight.mp4})"
exit "$status"
