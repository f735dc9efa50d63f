#!/usr/bin/env bash
# The link record of a short lockstep flight (link_record.yaml: the ground station's commands cross the
# radio) read by an independent reader, node-mavlink (tools/node/tlog_check.js): every record one frame
# with a valid CRC, time stamps in order, both directions present, and as many records as the simulator
# says it wrote (summary.json links.link_record.records).
#   link_record_check.sh QUAD_SIM NODE NODE_DIR SCENARIO DIALECT_XML OUT_DIR
set -euo pipefail
sim=$1 node=$2 node_dir=$3 scenario=$4 dialect=$5 out=$6
rm -rf "$out"
"$sim" --scenario "$scenario" --out "$out" --no-plots --quiet
[ -s "$out/link.tlog" ] || { echo "FAILED: $out/link.tlog is missing or empty"; exit 1; }
report=$("$node" "$node_dir/tlog_check.js" "$out/link.tlog" --dialect "$dialect" \
  --require HEARTBEAT@1:6 --require LOCAL_POSITION_NED@1:50 --require COMMAND_ACK@1:2 --require PARAM_VALUE@1:50 \
  --require LANDING_TARGET@1:200 --require COMMAND_LONG@255:2 --require SET_POSITION_TARGET_LOCAL_NED@255 \
  --require PARAM_REQUEST_LIST@255)
echo "$report"
read_records=$(echo "$report" | sed -n 's/^records \([0-9]*\) .*/\1/p')
written=$(sed -n 's/.*"records": \([0-9]*\).*/\1/p' "$out/summary.json")
if [ "$read_records" != "$written" ]; then
  echo "FAILED: node-mavlink read $read_records records, the simulator wrote $written"
  exit 1
fi
echo "link record: $written records, as written"
