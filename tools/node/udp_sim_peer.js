// What the node-mavlink peers of `quad_sim --gcs udp:...` share (udp_gcs_peer.js, external_pose_peer.js):
// their command line, the ground side of the UDP link, and the run that starts the simulator against a
// socket of 127.0.0.1, runs the peer's steps in order and stops the simulator with SIGINT.
'use strict';

const dgram = require('dgram');
const { spawn } = require('child_process');
const {
  minimal, common, MavLinkProtocolV2, MavLinkPacketSplitter, MavLinkPacketParser,
} = require('node-mavlink');

const VEHICLE = { system: 1, component: 1 };

// `--sim --scenario --out` and the peer's own `flags` (each with a value, all required), then
// `-- EXTRA SIM ARGS`. A bad command line prints `program: what, usage` and exits with status 2.
function parsePeerArguments(argv, program, flags, usageLine) {
  const usage = (message) => {
    console.error(`${program}: ${message}\nusage: ${usageLine}`);
    process.exit(2);
  };
  const names = ['sim', 'scenario', 'out', ...flags];
  const o = { extra: [] };
  for (let i = 0; i < argv.length; ++i) {
    const a = argv[i];
    if (a === '--') {
      o.extra = argv.slice(i + 1);
      break;
    }
    const key = a.startsWith('--') ? a.slice(2) : null;
    if (!names.includes(key)) usage(`unknown argument ${a}`);
    if (i + 1 >= argv.length) usage(`${a} needs a value`);
    o[key] = argv[++i];
  }
  for (const k of names) if (!o[k]) usage(`--${k} is required`);
  return o;
}

// The ground side of the UDP link: node-mavlink frames and parses; the peer is whoever the vehicle's
// datagrams come from.
class UdpMavlinkPeer {
  constructor(socket, system, component) {
    this.socket = socket;
    this.protocol = new MavLinkProtocolV2(system, component);
    this.sequence = 0;
    this.peer = null;
    this.waiters = [];
    this.received = 0;
    this.registry = { ...minimal.REGISTRY, ...common.REGISTRY };
    this.splitter = new MavLinkPacketSplitter();
    this.splitter.pipe(new MavLinkPacketParser()).on('data', (packet) => this.dispatch(packet));
    socket.on('message', (datagram, from) => {
      this.peer = { address: from.address, port: from.port };
      this.splitter.write(datagram);
    });
  }

  dispatch(packet) {
    const clazz = this.registry[packet.header.msgid];
    if (!clazz || packet.header.sysid !== VEHICLE.system) return;
    ++this.received;
    const message = packet.protocol.data(packet.payload, clazz);
    for (const w of [...this.waiters]) w(clazz.MSG_NAME, message, packet);
  }

  send(message) {
    if (!this.peer) throw new Error('no datagram from the vehicle yet: nowhere to send');
    const bytes = this.protocol.serialize(message, this.sequence);
    this.sequence = (this.sequence + 1) & 255;
    this.socket.send(bytes, this.peer.port, this.peer.address);
  }

  // Calls onMessage(name, message, packet) for every vehicle message until it returns a value other
  // than undefined (resolves with it) or timeoutMs pass (resolves with undefined).
  collect(timeoutMs, onMessage) {
    return new Promise((resolve) => {
      const waiter = (name, message, packet) => {
        const result = onMessage(name, message, packet);
        if (result !== undefined) finish(result);
      };
      const timer = setTimeout(() => finish(undefined), timeoutMs);
      const finish = (result) => {
        clearTimeout(timer);
        this.waiters = this.waiters.filter((w) => w !== waiter);
        resolve(result);
      };
      this.waiters.push(waiter);
    });
  }

  waitFor(name, timeoutMs, predicate = () => true) {
    return this.collect(timeoutMs, (n, m) => (n === name && predicate(m) ? m : undefined));
  }
}

// Binds a socket on a free port of 127.0.0.1, makes the peer on it (makePeer(socket)), starts the
// simulator with `--gcs udp:127.0.0.1:PORT --realtime`, and runs the steps in order: each takes the peer
// and `run`, returns the text of its `step NAME: ok ...` line, and throws to fail (`step NAME: FAILED
// ....). Stops at the first failure or when the simulator ends; then `finish(peer, run)` (optional),
// SIGINT to the simulator (its run folder keeps link.tlog and summary.json), and the process exits with
// status 0 when every step passed, else 1.
async function runStepsAgainstSim(o, { who, makePeer, steps, run, finish }) {
  const socket = dgram.createSocket('udp4');
  await new Promise((resolve) => socket.bind(0, '127.0.0.1', resolve));
  const port = socket.address().port;
  const peer = makePeer(socket);
  const args = ['--scenario', o.scenario, '--out', o.out, '--gcs', `udp:127.0.0.1:${port}`, '--realtime',
    '--no-plots', '--quiet', ...o.extra];
  console.log(`${who} on udp 127.0.0.1:${port}; ${o.sim} ${args.join(' ')}`);
  const sim = spawn(o.sim, args, { stdio: ['ignore', 'inherit', 'inherit'] });
  let simExit = null;
  const exited = new Promise((resolve) => sim.on('exit', (code, signal) => {
    simExit = { code, signal };
    resolve();
  }));
  let failed = false;
  for (const step of steps) {
    if (simExit) {
      console.log(`step ${step.name}: FAILED the simulator ended (status ${simExit.code}) before it`);
      failed = true;
      break;
    }
    try {
      console.log(`step ${step.name}: ok ${await step(peer, run)}`);
    } catch (e) {
      console.log(`step ${step.name}: FAILED ${e.message}`);
      failed = true;
      break;
    }
  }
  if (finish) finish(peer, run);
  if (!simExit) sim.kill('SIGINT');
  await exited;
  socket.close();
  console.log(`vehicle frames received ${peer.received}; simulator exit ${simExit.code ?? simExit.signal}`);
  process.exit(failed ? 1 : 0);
}

module.exports = { VEHICLE, parsePeerArguments, UdpMavlinkPeer, runStepsAgainstSim };
