#!/usr/bin/env node
// An independent reader of the link record (.tlog, docs/logging.md): node-mavlink checks a file the
// project's C++ wrote, with none of the project's code.
//
//   node tlog_check.js FILE.tlog [--dialect XML]... [--require NAME@SYSID[:MIN]]... [--min-records N]
//
// Every record must be an 8-byte big-endian time stamp (microseconds since the Unix epoch, between
// 2020 and a day from now) followed by exactly one MAVLink frame, the time stamps must never go back,
// and node-mavlink's own tlog reader (MavLinkTLogPacketSplitter + MavLinkPacketParser) must find the
// same frames at the same time stamps with no CRC error and no unknown message; each frame of a message
// node-mavlink defines must decode. --dialect adds the messages of a MAVLink XML definition (their
// CRC_EXTRA computed from the XML by mavlink-mappings-gen), e.g. link/mavlink/quad_pose.xml.
// --require NAME@SYSID[:MIN]: at least MIN (default 1) frames of message NAME from system SYSID.
// Prints one line per (system, component, message) with its count, then a summary line; exits 1 naming
// the first bad record (its number and byte offset) or the unmet requirement, 2 on usage errors.
'use strict';

const fs = require('fs');
const { Readable } = require('stream');
const {
  minimal, common, ardupilotmega, MavLinkProtocolV1, MavLinkProtocolV2, MavLinkTLogPacketSplitter,
  MavLinkPacketParser,
} = require('node-mavlink');
const { MSG_ID_MAGIC_NUMBER } = require('mavlink-mappings');
const { generateAll } = require('mavlink-mappings-gen');

const REGISTRY = { ...minimal.REGISTRY, ...common.REGISTRY, ...ardupilotmega.REGISTRY };
const EARLIEST_US = BigInt(Date.UTC(2020, 0, 1)) * 1000n;

function fail(message) {
  console.error(`tlog_check: ${message}`);
  process.exit(1);
}

function usage(message) {
  console.error(`tlog_check: ${message}\n` +
    'usage: node tlog_check.js FILE.tlog [--dialect XML]... [--require NAME@SYSID[:MIN]]... [--min-records N]');
  process.exit(2);
}

function parseArguments(argv) {
  const options = { file: null, dialects: [], requires: [], minRecords: 1 };
  for (let i = 0; i < argv.length; ++i) {
    const a = argv[i];
    const value = () => {
      if (i + 1 >= argv.length) usage(`${a} needs a value`);
      return argv[++i];
    };
    if (a === '--dialect') options.dialects.push(value());
    else if (a === '--min-records') options.minRecords = Number(value());
    else if (a === '--require') {
      const m = /^([A-Z0-9_]+)@(\d+)(?::(\d+))?$/.exec(value());
      if (!m) usage(`--require '${argv[i]}': expected NAME@SYSID[:MIN], e.g. HEARTBEAT@1:5`);
      options.requires.push({ name: m[1], sysid: Number(m[2]), min: m[3] === undefined ? 1 : Number(m[3]) });
    } else if (a.startsWith('--')) usage(`unknown option ${a}`);
    else if (options.file === null) options.file = a;
    else usage(`a second file '${a}'`);
  }
  if (options.file === null) usage('no file');
  return options;
}

// The message ids, CRC_EXTRA and names of extra XML definitions.
async function loadDialects(files) {
  const magic = { ...MSG_ID_MAGIC_NUMBER };
  const names = {};
  for (const file of files) {
    const { messages } = await generateAll(fs.readFileSync(file).toString(), { write: () => {} }, 'dialect');
    for (const m of messages) {
      magic[Number(m.id)] = m.magic;
      names[Number(m.id)] = m.name;
    }
  }
  return { magic, names };
}

// The frame's length from its header (MAVLink v2: 10-byte header, v1: 6), CRC and signature included.
function frameLength(buffer, at) {
  const stx = buffer[at];
  if (stx === MavLinkProtocolV2.START_BYTE) {
    const signed = (buffer[at + 2] & MavLinkProtocolV2.IFLAG_SIGNED) !== 0;
    return 10 + buffer[at + 1] + 2 + (signed ? 13 : 0);
  }
  if (stx === MavLinkProtocolV1.START_BYTE) return 6 + buffer[at + 1] + 2;
  return null;
}

// The records as the format defines them: time stamp, then one frame whose header gives its length.
function walkRecords(data) {
  const records = [];
  const latest = BigInt(Date.now() + 86400000) * 1000n;
  for (let at = 0, n = 1; at < data.length; ++n) {
    const where = `record ${n} at byte ${at}`;
    if (at + 8 + 3 > data.length) fail(`${where}: ${data.length - at} bytes left, too few for a time stamp and a frame`);
    const time = data.readBigUInt64BE(at);
    if (time < EARLIEST_US || time > latest) {
      fail(`${where}: time stamp ${time} us is not a time since the Unix epoch between 2020 and tomorrow`);
    }
    if (records.length > 0 && time < records[records.length - 1].time) {
      fail(`${where}: time stamp ${time} us goes back from ${records[records.length - 1].time} us`);
    }
    const length = frameLength(data, at + 8);
    if (length === null) fail(`${where}: byte 0x${data[at + 8].toString(16)} after the time stamp is no MAVLink start byte`);
    if (at + 8 + length > data.length) fail(`${where}: the frame (${length} bytes) is cut short by the end of the file`);
    records.push({ time, frame: data.subarray(at + 8, at + 8 + length), offset: at });
    at += 8 + length;
  }
  return records;
}

// node-mavlink's tlog reader over the whole file.
async function readWithNodeMavlink(data, magicNumbers) {
  const splitter = new MavLinkTLogPacketSplitter({}, { magicNumbers });
  const packets = [];
  await new Promise((resolve, reject) => {
    Readable.from([data]).pipe(splitter).pipe(new MavLinkPacketParser())
      .on('data', (p) => packets.push(p)).on('end', resolve).on('error', reject);
  });
  return { packets, invalid: splitter.invalidPackages, unknown: splitter.unknownPackagesCount };
}

async function main() {
  const options = parseArguments(process.argv.slice(2));
  const { magic, names } = await loadDialects(options.dialects);
  let data;
  try {
    data = fs.readFileSync(options.file);
  } catch (e) {
    fail(`${options.file}: ${e.message}`);
  }
  const records = walkRecords(data);
  if (records.length < options.minRecords) fail(`${options.file}: ${records.length} records, expected at least ${options.minRecords}`);

  const node = await readWithNodeMavlink(data, magic);
  if (node.invalid > 0) fail(`${options.file}: node-mavlink found ${node.invalid} frames with a bad CRC`);
  if (node.unknown > 0) fail(`${options.file}: node-mavlink found ${node.unknown} frames of unknown messages`);
  if (node.packets.length !== records.length) {
    fail(`${options.file}: node-mavlink's tlog reader found ${node.packets.length} frames, the records are ${records.length}`);
  }
  const counts = new Map();
  records.forEach((r, i) => {
    const p = node.packets[i];
    const where = `record ${i + 1} at byte ${r.offset}`;
    if (!p.buffer.equals(r.frame)) fail(`${where}: node-mavlink's frame differs from the record's`);
    if (BigInt(p.header.timestamp) !== r.time / 1000n) {
      fail(`${where}: node-mavlink read the time stamp ${p.header.timestamp} ms, the record holds ${r.time} us`);
    }
    const clazz = REGISTRY[p.header.msgid];
    if (clazz) {
      try {
        p.protocol.data(p.payload, clazz);
      } catch (e) {
        fail(`${where}: ${clazz.MSG_NAME} does not decode: ${e.message}`);
      }
    }
    const name = clazz ? clazz.MSG_NAME : (names[p.header.msgid] || `#${p.header.msgid}`);
    const key = `${p.header.sysid} ${p.header.compid} ${name}`;
    counts.set(key, (counts.get(key) || 0) + 1);
  });
  for (const key of [...counts.keys()].sort()) console.log(`${key} ${counts.get(key)}`);
  const span = Number(records[records.length - 1].time - records[0].time) / 1e6;
  console.log(`records ${records.length} span_s ${span.toFixed(3)} bytes ${data.length}`);

  for (const req of options.requires) {
    let n = 0;
    for (const [key, count] of counts) {
      const [sysid, , name] = key.split(' ');
      if (Number(sysid) === req.sysid && name === req.name) n += count;
    }
    if (n < req.min) fail(`${options.file}: ${n} ${req.name} frames from system ${req.sysid}, expected at least ${req.min}`);
  }
}

main().catch((e) => fail(e.stack || String(e)));
