#!/usr/bin/env bash
# tools/ulog_plots on the fixture flight's log (with the simulator's log.csv): every figure written as a
# whole PNG of some size; then on a copy of the log cut at half its size (inside a record's header or its
# body, depending on the flight), exit status 1 and a message naming the byte offset.
#   plots_check.sh ULOG_PLOTS FLIGHT_DIR
set -euo pipefail
plots="$1" flight="$2"
log="$flight/run/log_001.ulg" out="$flight/plots"
rm -rf "$out"
"$plots" "$log" --sim-log "$flight/run/log.csv" --out "$out"
status=0
for f in position velocity attitude motors vision_fixes vision_fix_residual vision_latency estimate_error track; do
  png="$out/$f.png"
  size=$(stat -c %s "$png" 2>/dev/null || echo 0)
  if [ "$size" -lt 15000 ] || [ "$(head -c 8 "$png" | od -An -tx1 | tr -d ' ')" != "89504e470d0a1a0a" ] ||
     [ "$(tail -c 8 "$png" | head -c 4)" != "IEND" ]; then
    echo "plots_check: $png missing, not a whole PNG or nearly empty ($size bytes)" >&2
    status=1
  fi
done
cut="$flight/cut.ulg"
size=$(stat -c %s "$log")
head -c $((size / 2)) "$log" > "$cut"
set +e
message=$("$plots" "$cut" --out "$flight/plots_cut" 2>&1)
rc=$?
set -e
if [ "$rc" -ne 1 ] || ! grep -qE "cut.ulg: byte [0-9]+: truncated: (message '.'|a message header)" <<< "$message"; then
  echo "plots_check: a cut log gave exit status $rc and: $message" >&2
  status=1
fi
exit $status
