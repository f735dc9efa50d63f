// A multi-vehicle HIL run (a scenario with `vehicles:`, docs/simulator.md "Several vehicles"): one
// MuJoCo world holding every vehicle (fleet_model.h, fleet_world.h), one firmware process per vehicle on
// its own HIL link (UART0) and radio (UART2), all in lockstep: each control period the simulator sends
// every vehicle its HIL_SENSOR, waits for every answer (the processes run in parallel), then moves the
// world one period. Each vehicle's fix comes from its fix source (fix_source.h); its ground side can be
// a UDP port of its own. Outputs: RUN/summary.json (the fleet and each vehicle), RUN/events.log, and
// RUN/<vehicle>/log.csv, firmware.log, firmware_params.txt.
#pragma once

#include "quad/sim/hil_session.h"
#include "quad/sim/scenario.h"

namespace quad::sim {

// `options` as for run_session(): out_dir, firmware_argv (a `--log-dir DIR` in it becomes each vehicle's
// folder), progress, stop, answer_timeout_s; gcs_udp HOST:PORT gives vehicle i (from 0) the peer
// HOST:PORT+i; realtime paces the lockstep run by the wall clock (never faster than real time).
SessionResult run_fleet_session(const Scenario& scenario, const SessionOptions& options);

}  // namespace quad::sim
