#!/usr/bin/env node
// A motion-capture feed made of node-mavlink, over a real UDP socket, against `quad_sim --gcs` (the
// simulator's ground-station bridge onto the emulated 57600-baud radio): it answers the address the
// vehicle's datagrams come from, learns the vehicle's clock with TIMESYNC, and sends the field's
// ATT_POS_MOCAP and the project's EXTERNAL_POSE_TARGETED (link/mavlink/quad_pose.xml; its class built
// here from what mavlink-mappings-gen writes for the XML) at 30 Hz to the vehicle standing on the
// ground, whose LOCAL_POSITION_NED must follow (docs/mavlink.md, "External pose"):
//
//   mocap          ATT_POS_MOCAP at P1: the estimate goes to P1
//   other_vehicle  EXTERNAL_POSE_TARGETED for system 2 alone, at P2, 1.6 m away, for 2.5 s: the estimate
//                  stays at P1 (taken, the position filter would reset to it after 20 refusals)
//   own_targeted   EXTERNAL_POSE_TARGETED for system 1 at P3, 8 cm from P1: the estimate goes to P3
//
//   node external_pose_peer.js --sim QUAD_SIM --scenario FILE --out DIR --dialect XML [-- EXTRA SIM ARGS]
//
// Each step prints `step NAME: ok ...` or `step NAME: FAILED ...`. Exit status 0 all steps passed; 1 a
// step failed or the simulator ended early; 2 usage.
'use strict';

const fs = require('fs');
const os = require('os');
const path = require('path');
const { execFileSync } = require('child_process');
const { common, MavLinkData, MavLinkPacketField } = require('node-mavlink');
const { VEHICLE, parsePeerArguments, UdpMavlinkPeer, runStepsAgainstSim } = require('./udp_sim_peer.js');

const RATE_HZ = 30;
const P1 = [0.25, -0.15, -0.13];
const P2 = [1.5, 0.6, -1.0];
const P3 = [0.33, -0.15, -0.13];

// The dialect's EXTERNAL_POSE_TARGETED as a node-mavlink class: mavlink-mappings-gen's command line
// (as the XML's comment says) run on a copy of the XML, and the message's id, CRC_EXTRA, length and
// fields (wire offsets included) read from the TypeScript it writes.
function dialectClass(xml, name) {
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'quad_pose_gen_'));
  const copy = path.join(dir, path.basename(xml));
  fs.copyFileSync(xml, copy);
  const cli = require.resolve('mavlink-mappings-gen/dist/cli.js');
  execFileSync(process.execPath, [cli, '-m', copy], { cwd: dir, stdio: 'ignore' });
  const ts = fs.readFileSync(copy.replace(/\.xml$/, '.ts'), 'utf8');
  const at = ts.indexOf(`static MSG_NAME = '${name}'`);
  if (at < 0) throw new Error(`${xml}: mavlink-mappings-gen wrote no ${name}`);
  const body = ts.slice(at, ts.indexOf('\n}', at));
  const number = (key) => Number(new RegExp(`static ${key} = (\\d+)`).exec(body)[1]);
  class Generated extends MavLinkData {}
  Generated.MSG_ID = Number(/static MSG_ID = (\d+)/.exec(ts.slice(ts.lastIndexOf('export class', at), at))[1]);
  Generated.MSG_NAME = name;
  Generated.PAYLOAD_LENGTH = number('PAYLOAD_LENGTH');
  Generated.MAGIC_NUMBER = number('MAGIC_NUMBER');
  Generated.FIELDS = [];
  const field = /new MavLinkPacketField\('(\w+)', '(\w+)', (\d+), (true|false), (\d+), '([\w\[\]]+)', '([^']*)'(?:, (\d+))?\)/g;
  for (let m; (m = field.exec(body));) {
    Generated.FIELDS.push(new MavLinkPacketField(m[1], m[2], Number(m[3]), m[4] === 'true', Number(m[5]), m[6],
      m[7], m[8] ? Number(m[8]) : 0));
  }
  fs.rmSync(dir, { recursive: true, force: true });
  if (Generated.FIELDS.length === 0) throw new Error(`${name}: no fields in the generated TypeScript`);
  return Generated;
}

// The vision/mocap component of the ground side; it learns the vehicle's clock (timesync step).
class UdpFeed extends UdpMavlinkPeer {
  constructor(socket) {
    super(socket, 1, 197);
    this.offsetNs = null;  // vehicle clock minus this process' clock
  }

  // The vehicle's clock now, in microseconds (TIMESYNC: the answer's tc1 against the request's mid-time).
  vehicleUsec() {
    return (process.hrtime.bigint() + this.offsetNs) / 1000n;
  }
}

function distance(p, q) {
  return Math.hypot(p.x - q[0], p.y - q[1], p.z - q[2]);
}

function mocap(gs, p) {
  const m = new common.MotionCaptureAttPos();
  m.timeUsec = gs.vehicleUsec() - 5000n;  // captured 5 ms before it is sent
  m.q = [1, 0, 0, 0];
  [m.x, m.y, m.z] = p;
  m.covariance = new Array(21).fill(0);
  m.covariance[0] = m.covariance[6] = m.covariance[11] = 1e-4;  // 1 cm per axis
  m.covariance[15] = m.covariance[18] = m.covariance[20] = 1e-4;
  return m;
}

function targeted(gs, Targeted, system, p) {
  const m = new Targeted();
  m.targetSystem = system;
  m.timeUsec = gs.vehicleUsec() - 5000n;
  [m.x, m.y, m.z] = p;
  m.q = [NaN, 0, 0, 0];
  m.positionVariance = [1e-4, 1e-4, 1e-4];
  m.attitudeVariance = NaN;
  return m;
}

// Sends make() every 1 / RATE_HZ s until stop() is called.
function stream(gs, make) {
  const timer = setInterval(() => gs.send(make()), 1000 / RATE_HZ);
  return () => clearInterval(timer);
}

const STEPS = [
  async function timesync(gs) {
    await gs.waitFor('HEARTBEAT', 10000);
    for (let attempt = 0; attempt < 5 && gs.offsetNs === null; ++attempt) {
      const req = new common.TimeSync();
      req.tc1 = 0n;
      req.ts1 = process.hrtime.bigint();
      const answer = gs.waitFor('TIMESYNC', 1000, (a) => BigInt(a.ts1) === req.ts1 && BigInt(a.tc1) !== 0n);
      gs.send(req);
      const a = await answer;
      if (a) gs.offsetNs = BigInt(a.tc1) - (req.ts1 + process.hrtime.bigint()) / 2n;
    }
    if (gs.offsetNs === null) throw new Error('no TIMESYNC answer');
    return `vehicle clock ${gs.vehicleUsec()} us`;
  },
  async function mocapTaken(gs, run) {
    run.stopMocap = stream(gs, () => mocap(gs, P1));
    const at = await gs.waitFor('LOCAL_POSITION_NED', 6000, (p) => distance(p, P1) < 0.02);
    if (!at) throw new Error(`LOCAL_POSITION_NED never within 2 cm of ${P1}`);
    return `LOCAL_POSITION_NED ${at.x.toFixed(3)} ${at.y.toFixed(3)} ${at.z.toFixed(3)}`;
  },
  async function otherVehicleIgnored(gs, run) {
    // Alone: beside the vehicle's own fixes a pose 1.6 m away would only be refused by the gate.
    run.stopMocap();
    const stop = stream(gs, () => targeted(gs, run.Targeted, 2, P2));
    let worst = 0;
    let count = 0;
    await gs.collect(2500, (name, p) => {
      if (name !== 'LOCAL_POSITION_NED') return undefined;
      worst = Math.max(worst, distance(p, P1));
      ++count;
      return undefined;
    });
    stop();
    if (count < 10) throw new Error(`only ${count} LOCAL_POSITION_NED in 2.5 s`);
    if (worst > 0.03) throw new Error(`the estimate moved ${worst.toFixed(3)} m from P1 towards system 2's pose`);
    return `${count} positions, at most ${worst.toFixed(3)} m from P1`;
  },
  async function ownTargetedTaken(gs, run) {
    const stop = stream(gs, () => targeted(gs, run.Targeted, VEHICLE.system, P3));
    const at = await gs.waitFor('LOCAL_POSITION_NED', 6000, (p) => distance(p, P3) < 0.02);
    stop();
    if (!at) throw new Error(`LOCAL_POSITION_NED never within 2 cm of ${P3}`);
    return `LOCAL_POSITION_NED ${at.x.toFixed(3)} ${at.y.toFixed(3)} ${at.z.toFixed(3)}`;
  },
];

async function main() {
  const o = parsePeerArguments(process.argv.slice(2), 'external_pose_peer', ['dialect'],
    'node external_pose_peer.js --sim QUAD_SIM --scenario FILE --out DIR --dialect XML [-- EXTRA SIM ARGS]');
  const run = { Targeted: dialectClass(o.dialect, 'EXTERNAL_POSE_TARGETED') };
  console.log(`EXTERNAL_POSE_TARGETED: id ${run.Targeted.MSG_ID}, CRC_EXTRA ${run.Targeted.MAGIC_NUMBER}, ` +
    `${run.Targeted.PAYLOAD_LENGTH} bytes`);
  await runStepsAgainstSim(o, {
    who: 'feed',
    makePeer: (socket) => new UdpFeed(socket),
    steps: STEPS,
    run,
    finish: (feed, r) => { if (r.stopMocap) r.stopMocap(); },  // (clearInterval twice is harmless)
  });
}

main().catch((e) => {
  console.error(`external_pose_peer: ${e.stack || e}`);
  process.exit(1);
});
