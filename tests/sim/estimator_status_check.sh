#!/usr/bin/env bash
# The health report in a flight (estimator_status.yaml) read by an independent peer, node-mavlink
# (tools/node/estimator_status_check.js): an arm command before the estimator converged refused with a
# PREFLIGHT line, ESTIMATOR_STATUS's flags on the ground, after the first fix and in the hold, test
# ratios below 1 in the hold. EST_TYPE picks the estimator (0 the thesis pair, 1 the EKF).
#   estimator_status_check.sh QUAD_SIM NODE NODE_DIR SCENARIO EST_TYPE OUT_DIR
set -euo pipefail
sim=$1 node=$2 node_dir=$3 scenario=$4 est_type=$5 out=$6
[ -x "$node" ] || { echo "FAILED: node ('$node') not found: tools/packages-debian.txt"; exit 1; }
rm -rf "$out"
"$sim" --scenario "$scenario" --out "$out" --no-plots --quiet --set "firmware_params.EST_TYPE=$est_type"
[ -s "$out/link.tlog" ] || { echo "FAILED: $out/link.tlog is missing or empty"; exit 1; }
# The thesis pair's accuracy is its model's: table 8.1's Q (1 m^2/s on the position) keeps sqrt(P_xx + P_yy)
# about 0.3 m between fixes at 30 Hz; the EKF's is millimetres.
accuracy=0.05
[ "$est_type" = 0 ] && accuracy=0.5
"$node" "$node_dir/estimator_status_check.js" "$out/link.tlog" --hold 9,14 --max-accuracy "$accuracy"
