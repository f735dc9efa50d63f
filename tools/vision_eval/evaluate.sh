#!/bin/sh
# Measures the vision station on independently generated stereo sets (docs/vision_station.md,
# "Evaluation on independent sets"): renders chessboards and calibrates the station from them
# (`vision_station calibrate`), renders the sets, runs `vision_station detect` with each configuration
# and scores the fixes against the truth.
#   tools/vision_eval/evaluate.sh [--split heldout|tune] [--stars N] [--data DIR] [--bin DIR] [--views N]
#                                 [--runs "default thesis ..."] [--markdown OUT.md]
#                                 [--check MIN_RATE,MAX_FALSE,MAX_MEDIAN] [--doc docs/vision_station.md]
#                                 [--prepare]
# Runs (station settings): default (deinterlace: field), robust_none, robust_blend, thesis (all by
# default); robust_field is the default spelled out.
# --check fails (exit 1) when the first run, over all conditions, finds fewer than MIN_RATE % of the
# stars in full view, makes more than MAX_FALSE false fixes or has a median error above MAX_MEDIAN %.
# --prepare renders the calibration and the sets when they are missing, and stops there (the speed
# benchmark's input: sim/campaigns/vision_speed.yaml).
# Defaults: held-out split, 520 stars in full view per condition (+ 1/3 as many pairs without), 96
# chessboard pairs for the calibration, data in build/host/vision_eval, binaries in build/host/bin. Sets
# and calibration are reused when present (the calibration is made again for another --views).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
split=heldout
stars=520
data="$root/build/host/vision_eval"
bin="$root/build/host/bin"
runs="default robust_none robust_blend thesis"
markdown=""
check=""
doc=""
prepare=""
views=96
args="$*"
while [ $# -gt 0 ]; do
  case "$1" in
    --split) split=$2; shift 2 ;;
    --stars) stars=$2; shift 2 ;;
    --data) data=$2; shift 2 ;;
    --bin) bin=$2; shift 2 ;;
    --views) views=$2; shift 2 ;;
    --runs) runs=$2; shift 2 ;;
    --markdown) markdown=$2; shift 2 ;;
    --check) check=$2; shift 2 ;;
    --doc) doc=$2; shift 2 ;;
    --prepare) prepare=1; shift ;;
    *) echo "evaluate.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
for exe in vision_eval_gen vision_station; do
  [ -x "$bin/$exe" ] || { echo "evaluate.sh: $bin/$exe missing (build it first)" >&2; exit 1; }
done
mkdir -p "$data"
# calib.views records how many chessboard pairs calib.yaml was estimated from.
if [ ! -f "$data/calib.yaml" ] || [ "$(cat "$data/calib.views" 2>/dev/null)" != "$views" ]; then
  rm -rf "$data/calib" "$data/calib.yaml" "$data/calib.views"
  "$bin/vision_eval_gen" chessboards --out "$data/calib" --views "$views"
  "$bin/vision_station" calibrate --images "$data/calib" --board 9x6 --square 0.03 --out "$data/calib.yaml" 2>/dev/null
  echo "$views" > "$data/calib.views"
fi
sets="$data/$split-$stars"
if [ ! -f "$sets/.complete" ]; then
  "$bin/vision_eval_gen" sets --out "$sets" --split "$split" --stars "$stars"
  touch "$sets/.complete"
fi
[ -z "$prepare" ] || exit 0
# Configurations: the default, each deinterlace choice, and the thesis pipeline as the baseline.
cfg="$data/configs"
mkdir -p "$cfg"
printf '%%YAML:1.0\n---\n' > "$cfg/default.yaml"
for d in none field blend; do printf '%%YAML:1.0\n---\ndeinterlace: %s\n' "$d" > "$cfg/robust_$d.yaml"; done
printf '%%YAML:1.0\n---\nmethod: thesis\ndeinterlace: none\n' > "$cfg/thesis.yaml"
score_args=""
for name in $runs; do
  settings="$cfg/$name.yaml"
  [ -f "$settings" ] || { echo "evaluate.sh: unknown run $name" >&2; exit 2; }
  out="$data/detect-$split-$stars/$name"
  mkdir -p "$out"
  for dir in "$sets"/*/; do
    condition=$(basename "$dir")
    echo "detect: $name $condition" >&2
    "$bin/vision_station" detect --calib "$data/calib.yaml" --settings "$settings" --pairs "$dir/pairs.csv" \
      > "$out/$condition.jsonl"
  done
  score_args="$score_args $name=$out"
done
# shellcheck disable=SC2086
python3 "$here/vision_eval.py" score --sets "$sets" --runs $score_args ${markdown:+--markdown "$markdown"} \
  ${check:+--check "$check"}
if [ -n "$doc" ]; then
  [ -n "$markdown" ] || { echo "evaluate.sh: --doc needs --markdown" >&2; exit 2; }
  python3 "$here/vision_eval.py" insert --doc "$doc" --marker vision_eval \
    --command "tools/vision_eval/evaluate.sh $args" --from "$markdown"
fi
