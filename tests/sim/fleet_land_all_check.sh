#!/usr/bin/env bash
# Land-all over the vehicles' own ground UDP ports: sim/scenarios/two_vehicles.yaml paced by the wall clock
# (--realtime) with --gcs, its scheduled land moved to 24 s; once both vehicles hold in AUTO (12 s in),
# tools/node/fleet_command.js land-all sends each one MAV_CMD_NAV_LAND over node-mavlink and must see both
# accepted (the COMMAND_ACK from each vehicle's system id: east is system 2, the firmware 1 behind its port);
# each firmware must then report LANDING before 24 s, and both end on the ground disarmed.
#   fleet_land_all_check.sh QUAD_SIM NODE NODE_DIR SCENARIO OUT_DIR
set -euo pipefail
sim=$1 node=$2 node_dir=$3 scenario=$4 out=$5
rm -rf "$out"
"$sim" --scenario "$scenario" --out "$out" --quiet --realtime --gcs udp:127.0.0.1:14950 \
  --set duration_s=30 --set commands.3.at_s=24 --set metrics.hold_end_s=20 &
sim_pid=$!
trap 'kill $sim_pid 2>/dev/null || true' EXIT
field() { "$node" -e "const j=JSON.parse(require('fs').readFileSync('$out/summary.json','utf8')); console.log($1)"; }
for _ in $(seq 1 60); do
  sleep 0.5
  [ -s "$out/summary.json" ] || continue
  if [ "$(field "j.sim_time_s >= 12 && Object.values(j.vehicles).every(v => v.mode_at_end === 'AUTO')")" = true ]; then break; fi
done
[ "$(field "j.sim_time_s >= 12")" = true ] || { echo "FAILED: the flight did not reach 12 s in AUTO"; exit 1; }
sent_at=$(field "j.sim_time_s.toFixed(1)")
"$node" "$node_dir/fleet_command.js" "$out" land-all
wait $sim_pid
trap - EXIT
for v in west east; do
  landing=$(sed -n "s/^ *\([0-9.]*\) $v: firmware: mode LANDING.*/\1/p" "$out/events.log" | head -1)
  [ -n "$landing" ] || { echo "FAILED: $v never reported LANDING"; exit 1; }
  "$node" -e "process.exit($landing < 24 ? 0 : 1)" || { echo "FAILED: $v landed at $landing s, not on land-all"; exit 1; }
  echo "$v: LANDING at $landing s (land-all sent near $sent_at s)"
done
[ "$(field "Object.values(j.vehicles).every(v => !v.armed_at_end && !v.crashed)")" = true ] ||
  { echo "FAILED: a vehicle is still armed or crashed"; cat "$out/summary.json"; exit 1; }
# east is system 2 at its port: its frames restamped, the tool's COMMAND_LONG to 2 readdressed to the firmware's 1.
[ "$(field "j.vehicles.east.system_id === 2 && j.vehicles.east.ground_ids.readdressed >= 1 && j.vehicles.east.ground_ids.restamped > 0")" = true ] ||
  { echo "FAILED: east (system 2) was not translated at its port"; cat "$out/summary.json"; exit 1; }
echo "land-all: both vehicles landed and disarmed; east answered as system 2"
