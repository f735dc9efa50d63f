#!/usr/bin/env bash
# Flies one HIL scenario with the simulator, the host firmware and (when present) the vision station.
set -euo pipefail
cd "$(dirname "$0")/.."
scenario="${1:-sim/scenarios/hover.yaml}"
sim=build/host/bin/quad_sim
if [ ! -x "$sim" ]; then
  echo "flight: $sim is not built yet: the HIL simulator has not landed (see the simulator issue)." >&2
  exit 1
fi
exec "$sim" --scenario "$scenario"
