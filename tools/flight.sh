#!/usr/bin/env bash
# `make flight`: flies one scenario headless with the simulator, the host firmware and the
# vision station in the loop (default sim/scenarios/flight.yaml: take off, climb to 1.5 m above the star,
# hold 60 s, land), then prints this run's figures beside the thesis' and Oh et al.'s.
#   tools/flight.sh [SCENARIO] [--out DIR] [--video] [--target avr|cortex-m4 [--host-run DIR]]
#   FLIGHT_VIDEO=1 make flight                            also renders a chase-camera MP4 (slower)
#   make flight TARGET=avr | TARGET=cortex-m4             the board's HIL image in the loop instead
# The run folder (default runs/<scenario>-<UTC time>) holds log.csv, events.log, summary.json, the PNG
# plots, firmware.log, station.log, report.txt and, with --video, flight.mp4. The station learns the
# cameras from chessboards the simulator renders (`vision_station calibrate`, cached in
# build/host/bin/station_calibration/ until the cameras or the station change; docs/simulator.md).
# --target flies the cross image on its emulated processor (avr: apm25_hil.elf on simavr through avr_pil;
# cortex-m4: mps2_hil.elf on QEMU through qemu_pil), run folder runs/<scenario>-<target>-<UTC time>, and
# reports it beside a host flight of the same scenario and seed: --host-run DIR, else the latest complete
# host flight of that seed under runs/, else one flown first into <run folder>/host.
set -euo pipefail
cd "$(dirname "$0")/.."

scenario=sim/scenarios/flight.yaml
out=""
video="${FLIGHT_VIDEO:-0}"
target=""
host_run=""
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    --video) video=1; shift ;;
    --target) target="$2"; shift 2 ;;
    --host-run) host_run="$2"; shift 2 ;;
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
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
firmware=()
case "$target" in
  "") ;;
  avr) image=build/avr-apm25/firmware/targets/avr/apm25_hil.elf launcher="$bin/avr_pil" ;;
  cortex-m4) image=build/cortex-m4/firmware/targets/cortexm/mps2_hil.elf launcher="$bin/qemu_pil" ;;
  *) echo "flight: --target must be avr or cortex-m4, not '$target'" >&2; exit 2 ;;
esac
if [ -n "$target" ]; then
  [ -r "$image" ] || { echo "flight: $image is not built (make $target)" >&2; exit 1; }
  [ -x "$launcher" ] || { echo "flight: $launcher is not built (make build)" >&2; exit 1; }
  if [ "$target" = cortex-m4 ] && [ ! -x "$bin/param_image" ]; then
    echo "flight: $bin/param_image is not built (make build)" >&2
    exit 1
  fi
  firmware=(--firmware "$PWD/$launcher --elf $PWD/$image")
fi
name=$(sed -n 's/^name: *//p' "$scenario" | head -n 1)
if [ -z "$out" ]; then
  out="runs/${name:-flight}${target:+-$target}-$(date -u +%Y%m%dT%H%M%SZ)"
fi
mkdir -p "$out"
record=()
if [ "$video" = 1 ]; then
  command -v ffmpeg >/dev/null || { echo "flight: --video needs ffmpeg" >&2; exit 1; }
  record=(--record "$out/flight.mp4")
fi

if [ -n "$target" ] && [ -z "$host_run" ]; then
  # The latest complete host flight of this scenario and seed: runs/<name>-<UTC time>, or one flown for
  # an earlier board flight (runs/<name>-<target>-<UTC time>/host); newest first.
  seed=$(sed -n 's/^seed: *\([0-9]*\).*/\1/p' "$scenario" | head -n 1)
  for dir in $(ls -dt runs/"${name:-flight}"-[0-9]*Z runs/"${name:-flight}"-*-[0-9]*Z/host 2>/dev/null); do
    if python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); sys.exit(0 if s.get("complete") and str(s.get("seed"))==sys.argv[2] and s.get("scenario_file","").endswith(sys.argv[3]) else 1)' \
        "$dir/summary.json" "${seed:-1}" "$scenario" 2>/dev/null; then
      host_run="$dir"
      break
    fi
  done
fi

status=0
if [ -n "$target" ] && [ -z "$host_run" ]; then
  host_run="$out/host"
  echo "flight: no host flight of $scenario to compare with: flying one first -> $host_run"
  "$bin/quad_sim" --scenario "$scenario" --out "$host_run" --no-plots || status=$?
fi
echo "flight: $scenario -> $out (simulator, ${target:+the $target image on its emulated processor as the }firmware and vision station in lockstep; progress below)"
"$bin/quad_sim" --scenario "$scenario" --out "$out" "${firmware[@]}" "${record[@]}" || status=$?
echo
if [ -n "$target" ]; then
  python3 sim/plots/flight_report.py "$out" --target "$target" --image "$image" --host-run "$host_run" || status=1
else
  python3 sim/plots/flight_report.py "$out" || status=1
fi
echo
echo "flight: run folder $out (log.csv, summary.json, report.txt, *.png${record:+, flight.mp4})"
exit "$status"
