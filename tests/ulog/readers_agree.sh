#!/usr/bin/env bash
# The log's readers agree: ulog_dump (C++) and ulog.py (Python) print the same text for every record of
# LOG, and each topic's record count, first record, info and start parameters match what the field's
# reader (@foxglove/ulog, node) reads. Exit 77 (skipped) without node or @foxglove/ulog.
#   readers_agree.sh ULOG_DUMP LOG ROOT
set -euo pipefail
dump="$1" log="$2" root="$3"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$dump" --records "$log" > "$tmp/cpp.txt"
/usr/bin/python3 "$root/tools/ulog/ulog.py" --records "$log" > "$tmp/py.txt"
if ! diff -q "$tmp/cpp.txt" "$tmp/py.txt" > /dev/null; then
  echo "readers_agree: the C++ and Python readers differ on $log:" >&2
  diff "$tmp/cpp.txt" "$tmp/py.txt" | head -20 >&2
  exit 1
fi
echo "readers_agree: C++ and Python: $(wc -l < "$tmp/cpp.txt") identical lines"
if ! command -v node > /dev/null || [ ! -d "$root/tools/node/node_modules/@foxglove/ulog" ]; then
  echo "readers_agree: SKIPPED the comparison with @foxglove/ulog (node or tools/node/node_modules missing)"
  exit 77
fi
NODE_PATH="$root/tools/node/node_modules" node "$(dirname "$0")/foxglove_counts.js" "$log" > "$tmp/foxglove.txt"
# The same summary from the project's readers: counts, info, parameters, and each topic's first record.
{
  grep -E "^(topic|info|param) " "$tmp/cpp.txt"
  awk '/^[a-z_]+ [0-9]+:/ { name = $1; if (!(name in seen)) { seen[name] = 1; sub(/^[a-z_]+ [0-9]+: */, ""); print "first " name ": " $0 } }' "$tmp/cpp.txt"
} | sort > "$tmp/ours.txt"
if ! diff "$tmp/foxglove.txt" "$tmp/ours.txt" > "$tmp/diff.txt"; then
  echo "readers_agree: @foxglove/ulog reads $log otherwise:" >&2
  head -20 "$tmp/diff.txt" >&2
  exit 1
fi
echo "readers_agree: @foxglove/ulog: $(wc -l < "$tmp/foxglove.txt") lines agree (counts, first records, info, parameters)"
