#!/usr/bin/env bash
# Builds the libFuzzer targets (preset `fuzz`) and runs each for a set time.
#   tools/fuzz.sh [SECONDS_PER_TARGET] [SEED]     (default 60 s, a random seed)
# With a SEED the run is reproducible (make test's short run uses one, so CI judges the same inputs
# every time); without one each run explores new ground (make fuzz).
# The working corpus grows in build/fuzz/corpus/<target> (seeded from tests/fuzz/corpus/<target>);
# crashes land in build/fuzz/crashes/<target>/: copy each into tests/fuzz/regressions/<target>/ with
# its fix, so ctest replays it from then on.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
seed_opt=()
[ -n "${2:-}" ] && seed_opt=(-seed="$2")
jobs="$(nproc 2>/dev/null || echo 2)"

cmake --preset fuzz > build-fuzz-configure.log 2>&1 || { cat build-fuzz-configure.log; exit 1; }
rm -f build-fuzz-configure.log
cmake --build --preset fuzz --target fuzzers -j "$jobs"

status=0
total=0
printf '%-10s %14s %10s %8s\n' target executions exec/s crashes > build/fuzz/summary.txt
for exe in build/fuzz/fuzz/fuzz_*; do
  [ -x "$exe" ] || continue
  name="${exe##*/fuzz_}"
  corpus="build/fuzz/corpus/$name"
  crashes="build/fuzz/crashes/$name"
  mkdir -p "$corpus" "$crashes"
  echo "fuzz: $name for ${seconds}s"
  log="build/fuzz/$name.log"
  rc=0
  "$exe" "${seed_opt[@]}" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$crashes/" "$corpus" "tests/fuzz/corpus/$name" > "$log" 2>&1 || rc=$?
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  found=$(find "$crashes" -type f | wc -l)
  printf '%-10s %14s %10s %8s\n' "$name" "${runs:-?}" "${rate:-?}" "$found" >> build/fuzz/summary.txt
  total=$(( total + ${runs:-0} ))
  if [ "$rc" -ne 0 ] || [ "$found" -ne 0 ]; then
    echo "fuzz: $name FAILED (exit $rc); inputs in $crashes; last lines of $log:" >&2
    tail -30 "$log" >&2
    status=1
  fi
done
printf '%-10s %14s\n' total "$total" >> build/fuzz/summary.txt
cat build/fuzz/summary.txt
exit $status
