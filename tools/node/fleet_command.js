#!/usr/bin/env node
// Land-all and disarm-all for a multi-vehicle run (docs/simulator.md, "Several vehicles"): sends every
// vehicle of a running `quad_sim --gcs` fleet run a COMMAND_LONG on that vehicle's own ground UDP port,
// addressed to the vehicle's system id (both in RUN/summary.json: vehicles.NAME.gcs_udp_local_port and
// system_id), and waits for its COMMAND_ACK from that system id.
//
//   node fleet_command.js RUN_DIR land-all|disarm-all [--host 127.0.0.1] [--timeout-ms 3000]
//
// land-all: MAV_CMD_NAV_LAND (each vehicle descends where it is and disarms on the ground).
// disarm-all: MAV_CMD_COMPONENT_ARM_DISARM param1 0, param2 21196 (MAVLink's force: motors off at once,
// in the air too; the emergency stop).
// One line per vehicle: `NAME: accepted` or `NAME: FAILED (...)`. Exit status 0 every vehicle accepted;
// 1 one did not; 2 usage or no vehicle with a UDP port in the summary.
// The simulator sends a vehicle's datagrams to whoever sent to its port last, so a ground station on
// the same ports gets its stream back when it next sends (QGroundControl sends heartbeats every second).
'use strict';

const dgram = require('dgram');
const fs = require('fs');
const path = require('path');
const { minimal, common, MavLinkProtocolV2, MavLinkPacketSplitter, MavLinkPacketParser } = require('node-mavlink');

const REGISTRY = { ...minimal.REGISTRY, ...common.REGISTRY };
const MAV_CMD_NAV_LAND = 21;
const MAV_CMD_COMPONENT_ARM_DISARM = 400;
const FORCE_DISARM = 21196;

function usage(message) {
  console.error(`fleet_command: ${message}\n` +
    'usage: node fleet_command.js RUN_DIR land-all|disarm-all [--host 127.0.0.1] [--timeout-ms 3000]');
  process.exit(2);
}

function parseArguments(argv) {
  const o = { run: null, action: null, host: '127.0.0.1', timeoutMs: 3000 };
  const positional = [];
  for (let i = 0; i < argv.length; ++i) {
    if (argv[i] === '--host') o.host = argv[++i];
    else if (argv[i] === '--timeout-ms') o.timeoutMs = Number(argv[++i]);
    else if (argv[i].startsWith('--')) usage(`unknown option ${argv[i]}`);
    else positional.push(argv[i]);
  }
  if (positional.length !== 2) usage('RUN_DIR and an action are required');
  [o.run, o.action] = positional;
  if (!['land-all', 'disarm-all'].includes(o.action)) usage(`unknown action ${o.action}`);
  if (!(o.timeoutMs > 0)) usage('--timeout-ms must be a positive number');
  return o;
}

function vehiclePorts(run) {
  const file = path.join(run, 'summary.json');
  let summary;
  try {
    summary = JSON.parse(fs.readFileSync(file, 'utf8'));
  } catch (e) {
    usage(`${file}: ${e.message}`);
  }
  const ports = Object.entries(summary.vehicles || {})
    .filter(([, v]) => Number.isInteger(v.gcs_udp_local_port))
    .map(([name, v]) => ({ name, port: v.gcs_udp_local_port, system: v.system_id }));
  if (!ports.length) usage(`${file}: no vehicle has a ground UDP port (run quad_sim with --gcs)`);
  return ports;
}

// One vehicle: its own socket, the command sent up to three times until its COMMAND_ACK arrives.
function commandVehicle(host, vehicle, action, timeoutMs) {
  return new Promise((resolve) => {
    const socket = dgram.createSocket('udp4');
    const protocol = new MavLinkProtocolV2(255, 190);
    const splitter = new MavLinkPacketSplitter();
    const command = action === 'land-all' ? MAV_CMD_NAV_LAND : MAV_CMD_COMPONENT_ARM_DISARM;
    let sequence = 0;
    let attempts = 0;
    let timer = null;
    const finish = (line) => {
      clearTimeout(timer);
      socket.close();
      resolve(line);
    };
    splitter.pipe(new MavLinkPacketParser()).on('data', (packet) => {
      const clazz = REGISTRY[packet.header.msgid];
      if (!clazz || clazz.MSG_NAME !== 'COMMAND_ACK' || packet.header.sysid !== vehicle.system) return;
      const ack = packet.protocol.data(packet.payload, clazz);
      if (ack.command !== command) return;
      finish(ack.result === 0 ? `${vehicle.name}: accepted` : `${vehicle.name}: FAILED (COMMAND_ACK result ${ack.result})`);
    });
    socket.on('message', (datagram) => splitter.write(datagram));
    const send = () => {
      if (attempts++ === 3) return finish(`${vehicle.name}: FAILED (no COMMAND_ACK on port ${vehicle.port})`);
      const msg = new common.CommandLong();
      msg.targetSystem = vehicle.system;
      msg.targetComponent = 1;
      msg.command = command;
      if (action === 'disarm-all') [msg._param1, msg._param2] = [0, FORCE_DISARM];
      socket.send(protocol.serialize(msg, sequence++ & 255), vehicle.port, host);
      timer = setTimeout(send, timeoutMs / 3);
    };
    socket.bind(0, () => send());
  });
}

async function main() {
  const o = parseArguments(process.argv.slice(2));
  const lines = await Promise.all(vehiclePorts(o.run).map((v) => commandVehicle(o.host, v, o.action, o.timeoutMs)));
  for (const line of lines) console.log(line);
  process.exit(lines.every((l) => l.endsWith(': accepted')) ? 0 : 1);
}

main();
