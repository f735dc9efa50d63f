#!/usr/bin/env node
// The real MAVLink peer for the byte-compatibility test of the link codec (tests/link): node-mavlink
// encodes and decodes the messages of link/include/quad/link/messages.h.
//
//   node mavlink_peer.js encode SEED COUNT OUT.bin OUT.txt
//       COUNT frames of every message with random field values (some of them signed, some with zeroed
//       trailing fields so that payload truncation is exercised), serialised by node-mavlink into OUT.bin;
//       the values go to OUT.txt, one line per frame.
//   node mavlink_peer.js decode IN.bin OUT.txt
//       splits and parses IN.bin with node-mavlink's own splitter and parser and writes the values of
//       every frame to OUT.txt. Exits non-zero if any frame was invalid or of an unknown id.
//
// A line: NAME SEQ SYSID COMPID then the field values in wire order (the order of the definition's
// FIELDS, sorted by offset). Integers in decimal, floats as the 8 hex digits of their IEEE-754 single
// bits (exact), char arrays as hex bytes up to the first NUL ('-' when empty), arrays element by element.
// A signed frame ends with sig=<26 hex digits> (link id, timestamp, signature as on the wire).
'use strict';

const fs = require('fs');
const { Readable } = require('stream');
const {
  minimal, common, MavLinkProtocolV2, MavLinkPacketSplitter, MavLinkPacketParser,
} = require('node-mavlink');

const REGISTRY = { ...minimal.REGISTRY, ...common.REGISTRY };

// The messages the codec implements, by MAVLink name.
const MESSAGES = [
  'HEARTBEAT', 'SYS_STATUS', 'PARAM_REQUEST_READ', 'PARAM_REQUEST_LIST', 'PARAM_VALUE', 'PARAM_SET',
  'ATTITUDE_QUATERNION', 'LOCAL_POSITION_NED', 'MANUAL_CONTROL', 'COMMAND_LONG', 'COMMAND_ACK',
  'SET_POSITION_TARGET_LOCAL_NED', 'HIL_ACTUATOR_CONTROLS', 'VISION_POSITION_ESTIMATE', 'HIL_SENSOR',
  'TIMESYNC', 'HIL_STATE_QUATERNION', 'LOG_REQUEST_LIST', 'LOG_ENTRY', 'LOG_REQUEST_DATA', 'LOG_DATA',
  'LOG_ERASE', 'LOG_REQUEST_END', 'ATT_POS_MOCAP', 'LANDING_TARGET', 'ESTIMATOR_STATUS', 'EXTENDED_SYS_STATE',
  'STATUSTEXT',
];

function classByName(name) {
  const clazz = Object.values(REGISTRY).find((c) => c.MSG_NAME === name);
  if (!clazz) throw new Error(`node-mavlink has no message ${name}`);
  return clazz;
}

function wireFields(clazz) {
  return [...clazz.FIELDS].sort((a, b) => a.offset - b.offset);
}

// xorshift128+ seeded from one integer: reproducible runs for a given seed.
function makeRandom(seed) {
  let s0 = BigInt.asUintN(64, BigInt(seed) * 0x9E3779B97F4A7C15n + 1n);
  let s1 = BigInt.asUintN(64, s0 ^ 0xD1B54A32D192ED03n);
  const next64 = () => {
    let x = s0;
    const y = s1;
    s0 = y;
    x = BigInt.asUintN(64, x ^ (x << 23n));
    s1 = BigInt.asUintN(64, x ^ y ^ (x >> 17n) ^ (y >> 26n));
    return BigInt.asUintN(64, s1 + y);
  };
  return {
    bits(n) { return BigInt.asUintN(n, next64()); },
    below(n) { return Number(next64() % BigInt(n)); },
  };
}

const scratch = Buffer.alloc(8);

function floatBits(value) {
  scratch.writeFloatLE(value, 0);
  return scratch.readUInt32LE(0).toString(16).padStart(8, '0');
}

// A finite float32 from random bits (NaN payloads do not survive a round trip through a JS number).
function randomFloat(random) {
  for (;;) {
    scratch.writeUInt32LE(Number(random.bits(32)), 0);
    const value = scratch.readFloatLE(0);
    if (Number.isFinite(value)) return value;
  }
}

function randomScalar(type, random) {
  switch (type) {
    case 'float': return randomFloat(random);
    case 'uint64_t': return random.bits(64);
    case 'int64_t': return BigInt.asIntN(64, random.bits(64));
    case 'uint8_t':
    case 'uint8_t_mavlink_version': return Number(random.bits(8));
    case 'int8_t': return Number(BigInt.asIntN(8, random.bits(8)));
    case 'uint16_t': return Number(random.bits(16));
    case 'int16_t': return Number(BigInt.asIntN(16, random.bits(16)));
    case 'uint32_t': return Number(random.bits(32));
    case 'int32_t': return Number(BigInt.asIntN(32, random.bits(32)));
    default: throw new Error(`no random generator for ${type}`);
  }
}

function zeroOf(type) {
  return type === 'uint64_t' || type === 'int64_t' ? 0n : 0;
}

function randomValue(field, random, zero) {
  if (field.type === 'char[]') {
    if (zero) return '';
    const length = random.below(field.length + 1);
    let text = '';
    for (let i = 0; i < length; i++) text += String.fromCharCode(32 + random.below(95));
    return text;
  }
  if (field.type.endsWith('[]')) {
    const element = field.type.slice(0, -2);
    return Array.from({ length: field.length }, () => (zero ? zeroOf(element) : randomScalar(element, random)));
  }
  return zero ? zeroOf(field.type) : randomScalar(field.type, random);
}

function formatScalar(type, value) {
  if (type === 'float') return floatBits(value);
  return value.toString();
}

function formatValue(field, value) {
  if (field.type === 'char[]') {
    const bytes = Buffer.from(value, 'latin1');
    return bytes.length === 0 ? '-' : bytes.toString('hex');
  }
  if (field.type.endsWith('[]')) {
    const element = field.type.slice(0, -2);
    return value.map((v) => formatScalar(element, v)).join(' ');
  }
  return formatScalar(field.type, value);
}

function formatLine(clazz, header, data, signature) {
  const values = wireFields(clazz).map((field) => formatValue(field, data[field.name]));
  const sig = signature ? ` sig=${signature.toString('hex')}` : '';
  return `${clazz.MSG_NAME} ${header.seq} ${header.sysid} ${header.compid} ${values.join(' ')}${sig}`;
}

function encode(seed, count, binPath, textPath) {
  const random = makeRandom(seed);
  const frames = [];
  const lines = [];
  const key = Buffer.alloc(32, 0x5a);
  let seq = 0;
  for (let round = 0; round < count; round++) {
    for (const name of MESSAGES) {
      const clazz = classByName(name);
      const fields = wireFields(clazz);
      const message = new clazz();
      // A quarter of the frames have every field from a random one on set to zero: their payload is
      // truncated on the wire and must be zero-extended by the receiver.
      const zeroFrom = random.below(4) === 0 ? random.below(fields.length) : fields.length;
      fields.forEach((field, i) => { message[field.name] = randomValue(field, random, i >= zeroFrom); });
      const sysid = random.below(256);
      const compid = random.below(256);
      const protocol = new MavLinkProtocolV2(sysid, compid);
      let frame = protocol.serialize(message, seq);
      let signature = null;
      if (random.below(8) === 0) {
        // MAVLink signing (the incompat flag is part of the CRC, so it goes in before serialising).
        const signedProtocol = new MavLinkProtocolV2(sysid, compid, MavLinkProtocolV2.IFLAG_SIGNED);
        frame = signedProtocol.sign(signedProtocol.serialize(message, seq), random.below(256), key,
          Date.UTC(2026, 0, 1) + random.below(1e9));
        signature = frame.subarray(frame.length - 13);
      }
      frames.push(frame);
      lines.push(formatLine(clazz, { seq, sysid, compid }, message, signature));
      seq = (seq + 1) & 0xff;
    }
  }
  fs.writeFileSync(binPath, Buffer.concat(frames));
  fs.writeFileSync(textPath, lines.join('\n') + '\n');
}

function decode(binPath, textPath) {
  const splitter = new MavLinkPacketSplitter();
  const lines = [];
  let failures = 0;
  const reader = Readable.from([fs.readFileSync(binPath)]).pipe(splitter).pipe(new MavLinkPacketParser());
  reader.on('data', (packet) => {
    const clazz = REGISTRY[packet.header.msgid];
    if (!clazz || !MESSAGES.includes(clazz.MSG_NAME)) {
      failures++;
      console.error(`unexpected message id ${packet.header.msgid}`);
      return;
    }
    const data = packet.protocol.data(packet.payload, clazz);
    const signature = packet.signature
      ? packet.signature.buffer.subarray(packet.signature.buffer.length - 13) : null;
    lines.push(formatLine(clazz, packet.header, data, signature));
  });
  reader.on('end', () => {
    fs.writeFileSync(textPath, lines.join('\n') + (lines.length ? '\n' : ''));
    if (splitter.invalidPackages || splitter.unknownPackagesCount) {
      console.error(`node-mavlink rejected frames: ${splitter.invalidPackages} invalid, ` +
        `${splitter.unknownPackagesCount} unknown`);
      failures++;
    }
    process.exitCode = failures ? 1 : 0;
  });
}

function main(argv) {
  const [mode, ...args] = argv;
  if (mode === 'encode' && args.length === 4) {
    encode(Number(args[0]), Number(args[1]), args[2], args[3]);
  } else if (mode === 'decode' && args.length === 2) {
    decode(args[0], args[1]);
  } else {
    console.error('usage: mavlink_peer.js encode SEED COUNT OUT.bin OUT.txt | decode IN.bin OUT.txt');
    process.exitCode = 2;
  }
}

// signing_peer.js reuses the message list and the random values.
module.exports = { REGISTRY, MESSAGES, classByName, wireFields, makeRandom, randomValue };

if (require.main === module) main(process.argv.slice(2));
