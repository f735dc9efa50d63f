#!/usr/bin/env node
// An independent check of the vehicle's health report: node-mavlink reads a flight's link record (.tlog)
// and decodes ESTIMATOR_STATUS, STATUSTEXT, COMMAND_ACK and HEARTBEAT with none of the project's code.
//
//   node estimator_status_check.js FILE.tlog --hold START,END [--max-accuracy M] [--min-status N]
//
// Checks, on the vehicle's frames (system 1) in the order they were recorded:
//   - the first arm command is refused (COMMAND_ACK 400 DENIED) with a STATUSTEXT that starts
//     "PREFLIGHT: estimator not converged: " and names the reason, and a later one is accepted;
//   - at least N ESTIMATOR_STATUS (default 10), their time_usec increasing;
//   - standing disarmed before the accepted arm command, after the calibration (the last report with
//     ATTITUDE before it): CONST_POS_MODE set, POS_HORIZ_REL clear (no fix yet);
//   - POS_HORIZ_REL set in a later report (after the first fix);
//   - in the hold (time_usec within START..END s of the vehicle clock, the simulator's in HIL): every
//     report has ATTITUDE, VELOCITY_HORIZ, VELOCITY_VERT, POS_HORIZ_REL, POS_VERT_ABS and
//     PRED_POS_HORIZ_REL, neither CONST_POS_MODE nor ACCEL_ERROR, every test ratio finite and below 1,
//     and pos_horiz_accuracy below M (default 0.1 m).
// Prints the figures; exits 1 naming the first failed check, 2 on usage errors.
'use strict';

const fs = require('fs');
const { Readable } = require('stream');
const { minimal, common, MavLinkTLogPacketSplitter, MavLinkPacketParser } = require('node-mavlink');
const { MSG_ID_MAGIC_NUMBER } = require('mavlink-mappings');

const REGISTRY = { ...minimal.REGISTRY, ...common.REGISTRY };
const F = common.EstimatorStatusFlags;
const VEHICLE = 1;

function fail(message) {
  console.error(`estimator_status_check: FAILED: ${message}`);
  process.exit(1);
}

function usage(message) {
  console.error(`estimator_status_check: ${message}\n` +
    'usage: node estimator_status_check.js FILE.tlog --hold START,END [--max-accuracy M] [--min-status N]');
  process.exit(2);
}

function parseArguments(argv) {
  const o = { file: null, hold: null, maxAccuracy: 0.1, minStatus: 10 };
  for (let i = 0; i < argv.length; ++i) {
    const a = argv[i];
    const value = () => {
      if (i + 1 >= argv.length) usage(`${a} needs a value`);
      return argv[++i];
    };
    if (a === '--hold') {
      const m = /^([0-9.]+),([0-9.]+)$/.exec(value());
      if (!m) usage('--hold: expected START,END in seconds');
      o.hold = [Number(m[1]), Number(m[2])];
    } else if (a === '--max-accuracy') o.maxAccuracy = Number(value());
    else if (a === '--min-status') o.minStatus = Number(value());
    else if (a.startsWith('--')) usage(`unknown option ${a}`);
    else if (o.file === null) o.file = a;
    else usage(`a second file '${a}'`);
  }
  if (o.file === null) usage('no file');
  if (o.hold === null) usage('no --hold');
  return o;
}

async function readPackets(data) {
  const splitter = new MavLinkTLogPacketSplitter({}, { magicNumbers: MSG_ID_MAGIC_NUMBER });
  const packets = [];
  await new Promise((resolve, reject) => {
    Readable.from([data]).pipe(splitter).pipe(new MavLinkPacketParser())
      .on('data', (p) => packets.push(p)).on('end', resolve).on('error', reject);
  });
  if (splitter.invalidPackages > 0) fail(`${splitter.invalidPackages} frames with a bad CRC`);
  return packets;
}

function flagNames(flags) {
  return Object.keys(F).filter((k) => isNaN(Number(k)) && (flags & F[k]) !== 0).join('|') || '0';
}

function decode(packets) {
  const events = [];
  for (const p of packets) {
    if (p.header.sysid !== VEHICLE) continue;
    const clazz = REGISTRY[p.header.msgid];
    if (!clazz) continue;
    const name = clazz.MSG_NAME;
    if (!['ESTIMATOR_STATUS', 'STATUSTEXT', 'COMMAND_ACK', 'HEARTBEAT'].includes(name)) continue;
    events.push({ name, data: p.protocol.data(p.payload, clazz) });
  }
  return events;
}

// The index in `events` of the COMMAND_ACK that accepted the arm command.
function armedAt(events) {
  return events.findIndex((e) => e.name === 'COMMAND_ACK' && e.data.command === 400 && e.data.result === common.MavResult.ACCEPTED);
}

function checkArming(events) {
  const acks = events.filter((e) => e.name === 'COMMAND_ACK' && e.data.command === 400);
  if (acks.length < 2) fail(`${acks.length} COMMAND_ACK for MAV_CMD_COMPONENT_ARM_DISARM, expected the refusal and the arm`);
  if (acks[0].data.result !== common.MavResult.DENIED) fail(`the first arm command was not refused (result ${acks[0].data.result})`);
  if (!acks.some((a) => a.data.result === common.MavResult.ACCEPTED)) fail('no arm command was accepted');
  const texts = events.filter((e) => e.name === 'STATUSTEXT').map((e) => e.data.text.replace(/\0.*$/, ''));
  const preflight = texts.find((t) => t.startsWith('PREFLIGHT: estimator not converged: '));
  if (!preflight) fail(`no "PREFLIGHT: estimator not converged: <reason>" STATUSTEXT (texts: ${JSON.stringify(texts)})`);
  const reason = preflight.slice('PREFLIGHT: estimator not converged: '.length);
  if (reason.length === 0) fail('the PREFLIGHT line names no reason');
  console.log(`arming: first refused with "${preflight}", then accepted`);
}

function checkReports(events, o) {
  const reports = events.filter((e) => e.name === 'ESTIMATOR_STATUS').map((e) => e.data);
  const beforeArm = events.slice(0, armedAt(events)).filter((e) => e.name === 'ESTIMATOR_STATUS').map((e) => e.data);
  if (reports.length < o.minStatus) fail(`${reports.length} ESTIMATOR_STATUS, expected at least ${o.minStatus}`);
  for (let i = 1; i < reports.length; ++i) {
    if (reports[i].timeUsec <= reports[i - 1].timeUsec) fail(`ESTIMATOR_STATUS ${i}: time_usec ${reports[i].timeUsec} not after ${reports[i - 1].timeUsec}`);
  }
  const t = (r) => Number(r.timeUsec) * 1e-6;
  const firstFix = reports.findIndex((r) => (r.flags & F.POS_HORIZ_REL) !== 0);
  if (firstFix < 0) fail('POS_HORIZ_REL never set: no fix fused');
  const ground = beforeArm.filter((r) => (r.flags & F.ATTITUDE) !== 0);
  if (ground.length === 0) fail('no report with ATTITUDE before the arm (standing after the calibration)');
  const standing = ground[ground.length - 1];
  if ((standing.flags & F.CONST_POS_MODE) === 0 || (standing.flags & F.POS_HORIZ_REL) !== 0) {
    fail(`standing before the arm at ${t(standing).toFixed(2)} s: flags ${flagNames(standing.flags)}, expected CONST_POS_MODE without POS_HORIZ_REL`);
  }
  console.log(`standing: ${ground.length} reports with ATTITUDE before the arm, the last at ${t(standing).toFixed(2)} s: ${flagNames(standing.flags)}`);
  console.log(`first fix: POS_HORIZ_REL from ${t(reports[firstFix]).toFixed(2)} s: ${flagNames(reports[firstFix].flags)}`);

  const hold = reports.filter((r) => t(r) >= o.hold[0] && t(r) <= o.hold[1]);
  if (hold.length < 3) fail(`${hold.length} ESTIMATOR_STATUS in the hold ${o.hold[0]}-${o.hold[1]} s, expected at least 3`);
  const required = F.ATTITUDE | F.VELOCITY_HORIZ | F.VELOCITY_VERT | F.POS_HORIZ_REL | F.POS_VERT_ABS | F.PRED_POS_HORIZ_REL;
  const worst = { velRatio: 0, posHorizRatio: 0, posVertRatio: 0, magRatio: 0, posHorizAccuracy: 0, posVertAccuracy: 0 };
  for (const r of hold) {
    const at = `hold report at ${t(r).toFixed(2)} s`;
    if ((r.flags & required) !== required) fail(`${at}: flags ${flagNames(r.flags)} lack ${flagNames(required & ~r.flags)}`);
    if ((r.flags & (F.CONST_POS_MODE | F.ACCEL_ERROR)) !== 0) fail(`${at}: flags ${flagNames(r.flags)}`);
    for (const k of ['velRatio', 'posHorizRatio', 'posVertRatio', 'magRatio']) {
      if (!Number.isFinite(r[k]) || r[k] < 0 || r[k] >= 1) fail(`${at}: ${k} ${r[k]} not in [0, 1)`);
    }
    if (!(r.posHorizAccuracy > 0 && r.posHorizAccuracy < o.maxAccuracy)) fail(`${at}: pos_horiz_accuracy ${r.posHorizAccuracy} not in (0, ${o.maxAccuracy}) m`);
    for (const k of Object.keys(worst)) worst[k] = Math.max(worst[k], r[k]);
  }
  console.log(`hold ${o.hold[0]}-${o.hold[1]} s: ${hold.length} reports, flags ${flagNames(hold[hold.length - 1].flags)}; largest ` +
    `vel_ratio ${worst.velRatio.toPrecision(3)}, pos_horiz_ratio ${worst.posHorizRatio.toPrecision(3)}, pos_vert_ratio ` +
    `${worst.posVertRatio.toPrecision(3)}, mag_ratio ${worst.magRatio.toPrecision(3)}, pos_horiz_accuracy ` +
    `${worst.posHorizAccuracy.toFixed(4)} m, pos_vert_accuracy ${worst.posVertAccuracy.toFixed(4)} m`);
}

async function main() {
  const o = parseArguments(process.argv.slice(2));
  let data;
  try {
    data = fs.readFileSync(o.file);
  } catch (e) {
    fail(`${o.file}: ${e.message}`);
  }
  const events = decode(await readPackets(data));
  checkArming(events);
  checkReports(events, o);
  console.log('estimator status: all checks passed');
}

main().catch((e) => fail(e.stack || String(e)));
