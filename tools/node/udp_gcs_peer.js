#!/usr/bin/env node
// A ground station made of node-mavlink, over a real UDP socket, against `quad_sim --gcs` (the
// simulator's ground-station bridge, docs/logging.md "Ground stations over UDP"): it listens on a free
// port of 127.0.0.1 as QGroundControl listens on 14550, starts the simulator with
// `--gcs udp:127.0.0.1:PORT --realtime`, answers the address the vehicle's datagrams come from, and
// runs the steps below in order. Each step prints one line `step NAME: ok ...` or `step NAME: FAILED ...`.
//
//   node udp_gcs_peer.js --sim QUAD_SIM --scenario FILE --out DIR --modes DIALECT_H [-- EXTRA SIM ARGS]
//
// --modes: link/include/quad/link/dialect.h, where the flight-mode numbers are defined (the number of
// AUTO is read from it, as a user reads it from docs/mavlink.md). When every step has passed, the
// simulator is stopped with SIGINT (its run folder keeps link.tlog and summary.json). Exit status 0 all
// steps passed; 1 a step failed or the simulator ended early; 2 usage.
'use strict';

const fs = require('fs');
const { common } = require('node-mavlink');
const { VEHICLE, parsePeerArguments, UdpMavlinkPeer, runStepsAgainstSim } = require('./udp_sim_peer.js');

const MAV_MODE_FLAG_SAFETY_ARMED = 128;
const MAV_MODE_FLAG_CUSTOM_MODE_ENABLED = 1;
const MAV_RESULT_ACCEPTED = 0;

// The custom_mode number of a flight mode, from the X-macro list `X(kAuto, 2, "AUTO")`.
function flightModeNumber(header, name) {
  const m = new RegExp(`X\\(k\\w+,\\s*(\\d+),\\s*"${name}"\\)`).exec(fs.readFileSync(header, 'utf8'));
  if (!m) throw new Error(`${header}: no flight mode "${name}"`);
  return Number(m[1]);
}

// The ground station (QGroundControl's system id 255, component 190), which also sends commands.
class UdpGroundStation extends UdpMavlinkPeer {
  constructor(socket) {
    super(socket, 255, 190);
  }

  // COMMAND_LONG, answered by COMMAND_ACK of the same command (one attempt).
  async command(command, params, timeoutMs = 1500) {
    const msg = new common.CommandLong();
    msg.targetSystem = VEHICLE.system;
    msg.targetComponent = VEHICLE.component;
    msg.command = command;
    [msg._param1, msg._param2] = params;  // node-mavlink names COMMAND_LONG's params '_param1' ...
    const ack = this.waitFor('COMMAND_ACK', timeoutMs, (a) => a.command === command);
    this.send(msg);
    return ack;
  }
}

function paramName(value) {
  return String(value.paramId).replace(/\0.*$/s, '');
}

// The steps, in order. Each takes the ground station and the run's context, returns the text of its
// `ok` line, and throws to fail. A step added here runs after the ones before it (the vehicle armed in
// AUTO, climbing to the setpoint) and before the simulator is stopped.
const STEPS = [
  async function heartbeat(gs) {
    const hb = await gs.waitFor('HEARTBEAT', 20000);
    if (!hb) throw new Error('no HEARTBEAT from the vehicle within 20 s');
    return `HEARTBEAT from ${gs.peer.address}:${gs.peer.port}, custom_mode ${hb.customMode}`;
  },

  async function parameterList(gs, run) {
    const request = new common.ParamRequestList();
    request.targetSystem = VEHICLE.system;
    request.targetComponent = VEHICLE.component;
    const seen = new Map();
    let count = -1;
    const done = gs.collect(15000, (name, v) => {
      if (name !== 'PARAM_VALUE') return undefined;
      count = v.paramCount;
      seen.set(v.paramIndex, paramName(v));
      return seen.size >= count ? true : undefined;
    });
    gs.send(request);  // one request, no retry: the list must come complete over the radio
    if (!(await done)) throw new Error(`${seen.size} of ${count} parameters within 15 s`);
    for (let i = 0; i < count; ++i) if (!seen.has(i)) throw new Error(`index ${i} of ${count} missing`);
    if (new Set(seen.values()).size !== count) throw new Error('a parameter name came twice under two indices');
    run.parameters = new Set(seen.values());
    return `${count} parameters, every index 0..${count - 1} once (param_count ${count})`;
  },

  async function parameterSet(gs, run) {
    const name = 'LAND_SPEED';  // only the landing uses it, which this run does not reach
    if (!run.parameters.has(name)) throw new Error(`the vehicle has no ${name}`);
    const set = new common.ParamSet();
    set.targetSystem = VEHICLE.system;
    set.targetComponent = VEHICLE.component;
    set.paramId = name;
    set.paramValue = 0.625;  // exact in float
    set.paramType = common.MavParamType.REAL32;
    const ack = gs.waitFor('PARAM_VALUE', 3000, (v) => paramName(v) === name);
    gs.send(set);
    const v = await ack;
    if (!v) throw new Error(`no PARAM_VALUE for ${name} within 3 s`);
    if (v.paramValue !== 0.625) throw new Error(`${name} answered ${v.paramValue}, not 0.625`);
    return `${name} = ${v.paramValue} acknowledged by PARAM_VALUE`;
  },

  async function arm(gs) {
    // The firmware refuses to arm until its still calibration is over: try once a second.
    for (let attempt = 1; attempt <= 10; ++attempt) {
      const ack = await gs.command(common.MavCmd.COMPONENT_ARM_DISARM, [1, 0]);
      if (ack && ack.result === MAV_RESULT_ACCEPTED) return `COMMAND_ACK accepted (attempt ${attempt})`;
      await new Promise((r) => setTimeout(r, 1000));
    }
    throw new Error('arming not accepted in 10 attempts');
  },

  async function modeAuto(gs, run) {
    const heartbeat = gs.waitFor('HEARTBEAT', 5000, (hb) => hb.customMode === run.autoMode);
    const ack = await gs.command(common.MavCmd.DO_SET_MODE, [MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, run.autoMode]);
    if (!ack) throw new Error('no COMMAND_ACK for DO_SET_MODE');
    if (ack.result !== MAV_RESULT_ACCEPTED) throw new Error(`DO_SET_MODE refused (MAV_RESULT ${ack.result})`);
    const hb = await heartbeat;
    if (!hb) throw new Error(`no HEARTBEAT with custom_mode ${run.autoMode} within 5 s`);
    if ((hb.baseMode & MAV_MODE_FLAG_SAFETY_ARMED) === 0) throw new Error('HEARTBEAT in AUTO but not armed');
    return `COMMAND_ACK accepted, HEARTBEAT custom_mode ${hb.customMode} armed`;
  },

  async function setpointFollowed(gs) {
    const target = { x: 0, y: 0, z: -1.0 };
    const start = await gs.waitFor('LOCAL_POSITION_NED', 2000);
    const distance = (p) => Math.hypot(p.x - target.x, p.y - target.y, p.z - target.z);
    if (!start) throw new Error('no LOCAL_POSITION_NED');
    if (distance(start) < 0.5) throw new Error(`already ${distance(start).toFixed(2)} m from (0, 0, -1): nothing to follow`);
    const sp = new common.SetPositionTargetLocalNed();
    sp.targetSystem = VEHICLE.system;
    sp.targetComponent = VEHICLE.component;
    sp.coordinateFrame = common.MavFrame.LOCAL_NED;
    sp.typeMask = 0x38 | 0x1C0 | 0x400 | 0x800;  // position only: no velocity, acceleration, yaw, yaw rate
    [sp.x, sp.y, sp.z] = [target.x, target.y, target.z];
    const reached = gs.waitFor('LOCAL_POSITION_NED', 15000, (p) => distance(p) < 0.1);
    gs.send(sp);
    const p = await reached;
    if (!p) throw new Error(`not within 0.1 m of (0, 0, -1) within 15 s (started ${distance(start).toFixed(2)} m away)`);
    return `from ${distance(start).toFixed(3)} m to ${distance(p).toFixed(3)} m of (0, 0, -1), position (${p.x.toFixed(2)}, ` +
      `${p.y.toFixed(2)}, ${p.z.toFixed(2)}) at t ${(p.timeBootMs / 1000).toFixed(2)} s`;
  },

  // The flight's log, which the vehicle is writing: listed, and its first 4 500 bytes (the definitions)
  // downloaded with LOG_REQUEST_DATA, missing ranges asked for again, and compared with the file.
  async function logDownload(gs, run) {
    const list = new common.LogRequestList();
    list.targetSystem = VEHICLE.system;
    list.targetComponent = VEHICLE.component;
    [list.start, list.end] = [0, 0xffff];
    const entry = gs.waitFor('LOG_ENTRY', 3000);
    gs.send(list);
    const e = await entry;
    if (!e) throw new Error('no LOG_ENTRY within 3 s');
    if (e.numLogs < 1) throw new Error('the vehicle lists no log although it is armed');
    const wanted = Math.min(4500, e.size);
    const data = Buffer.alloc(wanted);
    const have = new Set();  // offsets of the 90-byte blocks received
    for (let round = 0; round < 10 && have.size * 90 < wanted; ++round) {
      let ofs = 0;
      while (have.has(ofs)) ofs += 90;
      const request = new common.LogRequestData();
      request.targetSystem = VEHICLE.system;
      request.targetComponent = VEHICLE.component;
      [request.id, request.ofs, request.count] = [e.id, ofs, wanted - ofs];
      const done = gs.collect(2000, (name, d) => {
        if (name !== 'LOG_DATA' || d.id !== e.id || d.count === 0) return undefined;
        const n = Math.min(d.count, wanted - d.ofs);
        if (n > 0) Buffer.from(d.data.slice(0, n)).copy(data, d.ofs);
        have.add(d.ofs);
        return have.size * 90 >= wanted ? true : undefined;
      });
      gs.send(request);
      await done;
    }
    if (have.size * 90 < wanted) throw new Error(`${have.size * 90} of ${wanted} bytes of log ${e.id} in 10 requests`);
    const file = findFile(run.out, `log_${String(e.id).padStart(3, '0')}.ulg`);
    if (!file) throw new Error(`no log_${e.id}.ulg in ${run.out}`);
    const written = fs.readFileSync(file).subarray(0, wanted);
    if (!written.equals(data)) throw new Error(`the downloaded bytes differ from ${file}'s first ${wanted}`);
    if (data.subarray(0, 7).toString('latin1') !== 'ULog\x01\x12\x35') throw new Error('not a ULog header');
    return `LOG_ENTRY id ${e.id} of ${e.numLogs} (${e.size} bytes so far); its first ${wanted} bytes downloaded ` +
      `in ${have.size} LOG_DATA, equal to ${file}`;
  },
];

// The first file called name under dir (the simulator's run folder is below --out).
function findFile(dir, name) {
  for (const entry of fs.readdirSync(dir, { withFileTypes: true })) {
    const path = `${dir}/${entry.name}`;
    if (entry.isFile() && entry.name === name) return path;
    if (entry.isDirectory()) {
      const found = findFile(path, name);
      if (found) return found;
    }
  }
  return null;
}

async function main() {
  const o = parsePeerArguments(process.argv.slice(2), 'udp_gcs_peer', ['modes'],
    'node udp_gcs_peer.js --sim QUAD_SIM --scenario FILE --out DIR --modes DIALECT_H [-- EXTRA SIM ARGS]');
  await runStepsAgainstSim(o, {
    who: 'ground station',
    makePeer: (socket) => new UdpGroundStation(socket),
    steps: STEPS,
    run: { autoMode: flightModeNumber(o.modes, 'AUTO'), out: o.out },
  });
}

main().catch((e) => {
  console.error(`udp_gcs_peer: ${e.stack || e}`);
  process.exit(1);
});
