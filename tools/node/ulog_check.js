#!/usr/bin/env node
// Reads a ULog file with the field's reader (@foxglove/ulog) and prints what it holds as JSON: the
// header's information and parameters, every topic with its record count, time range, whether its
// timestamps never decrease in file order, and its first and last records, the logged strings and the
// parameter changes in the data.
//
//   node tools/node/ulog_check.js FILE.ulg [--series TOPIC]...
//
// --series adds every record of TOPIC (all fields, timestamps in microseconds as numbers).
// Exit status: 0 read; 1 the file is not a whole ULog (bad magic, a record cut short, a data record of
// another size than its format, an unknown msg_id), with the reason on stderr; 2 bad arguments.
"use strict";

const fs = require("fs");
const { ULog, ChunkedReader, MessageType, parseMessage, messageSize, computeTimetampOffset } = require("@foxglove/ulog");
const { FileReader } = require("@foxglove/ulog/node");
const { readRawMessage } = require("@foxglove/ulog/dist/readMessage");

function usage(error) {
  process.stderr.write(`ulog_check: ${error}\nusage: node ulog_check.js FILE.ulg [--series TOPIC]...\n`);
  process.exit(2);
}

// JSON for parsed values: bigint as number (microseconds fit), typed arrays as arrays, NaN as null.
function plain(value) {
  if (typeof value === "bigint") return Number(value);
  if (typeof value === "number") return Number.isFinite(value) ? value : null;
  if (Array.isArray(value) || ArrayBuffer.isView(value)) return Array.from(value, plain);
  if (value !== null && typeof value === "object") {
    const out = {};
    for (const [k, v] of Object.entries(value)) out[k] = plain(v);
    return out;
  }
  return value;
}

async function check(file, seriesTopics) {
  const ulog = new ULog(new FileReader(file));
  await ulog.open();
  const header = ulog.header;
  const definitions = header.definitions;

  // The whole file in order, record by record, with the library's message reader: the time index
  // ULog.readMessages() uses is sorted by timestamp and would hide an order the writer got wrong.
  const filelike = new FileReader(file);
  await filelike.open();
  const size = filelike.size();
  const reader = new ChunkedReader(filelike);
  reader.seekTo(16);
  const topics = new Map();  // msg_id -> summary
  const logged = [];
  const paramChanges = [];
  let dataStarted = false;
  let dropouts = 0;
  for (;;) {
    const offset = reader.position();
    if (offset === size) break;
    if (size - offset < 3) throw new Error(`${file}: ${size - offset} bytes at offset ${offset} are not a whole record header (truncated)`);
    const declared = new DataView((await filelike.read(offset, 3)).buffer).getUint16(0, true);
    if (offset + 3 + declared > size) {
      throw new Error(`${file}: the record at offset ${offset} ('${String.fromCharCode((await filelike.read(offset + 2, 1))[0])}', ${declared} bytes) ends past the file's ${size} bytes (truncated)`);
    }
    const msg = await readRawMessage(reader, size);
    if (msg === undefined) throw new Error(`${file}: unreadable record at offset ${offset}`);
    switch (msg.type) {
      case MessageType.AddLogged:
        dataStarted = true;
        topics.set(msg.msgId, { name: msg.messageName, msgId: msg.msgId, count: 0, monotonic: true, records: [] });
        break;
      case MessageType.Data: {
        dataStarted = true;
        const topic = topics.get(msg.msgId);
        if (topic === undefined) throw new Error(`${file}: data record at offset ${offset} for msg_id ${msg.msgId}, which no add_logged record named`);
        const definition = definitions.get(topic.name);
        const expected = messageSize(definition, definitions);
        if (msg.data.byteLength !== expected) {
          throw new Error(`${file}: ${topic.name} record at offset ${offset} has ${msg.data.byteLength} bytes, its format ${expected}`);
        }
        const view = new DataView(msg.data.buffer, msg.data.byteOffset, msg.data.byteLength);
        const timestamp = view.getBigUint64(computeTimetampOffset(definition, definitions), true);
        if (topic.count > 0 && timestamp < topic.last_timestamp) {
          if (topic.monotonic) topic.first_decrease = { offset, timestamp: Number(timestamp), after: Number(topic.last_timestamp) };
          topic.monotonic = false;
        }
        if (topic.count === 0) topic.first_timestamp = timestamp;
        topic.last_timestamp = timestamp;
        topic.count += 1;
        const value = parseMessage(definition, definitions, view, 0);
        if (topic.count === 1) topic.first = plain(value);
        topic.last = value;
        if (seriesTopics.has(topic.name)) topic.records.push(plain(value));
        break;
      }
      case MessageType.Log:
        logged.push({ level: msg.logLevel, timestamp: Number(msg.timestamp), text: msg.message });
        break;
      case MessageType.Parameter:
        if (dataStarted) {
          const view = new DataView(msg.value.buffer, msg.value.byteOffset, msg.value.byteLength);
          paramChanges.push({ key: msg.key, value: view.getFloat32(0, true), offset });
        }
        break;
      case MessageType.Dropout:
        dropouts += 1;
        break;
      default:
        break;
    }
  }

  const out = {
    file,
    bytes: size,
    version: header.version,
    timestamp: Number(header.timestamp),
    info: plain(Object.fromEntries(header.information)),
    parameters: Object.fromEntries(Array.from(header.parameters, ([k, v]) => [k, plain(v.value)])),
    parameter_changes: paramChanges,
    library_counts: {},
    topics: {},
    logged,
    dropouts,
  };
  // The library's own index (sorted by time) must count what the walk in file order counted.
  for (const [id, n] of ulog.dataMessageCounts() ?? []) out.library_counts[ulog.subscriptions.get(id).name] = n;
  for (const topic of topics.values()) {
    out.topics[topic.name] = {
      msg_id: topic.msgId,
      fields: definitions.get(topic.name).fields.map((f) => (f.arrayLength ? `${f.type}[${f.arrayLength}] ${f.name}` : `${f.type} ${f.name}`)),
      record_bytes: 3 + 2 + messageSize(definitions.get(topic.name), definitions),
      count: topic.count,
      monotonic: topic.monotonic,
      first_decrease: topic.first_decrease,
      first_timestamp: topic.count > 0 ? Number(topic.first_timestamp) : null,
      last_timestamp: topic.count > 0 ? Number(topic.last_timestamp) : null,
      first: topic.first,
      last: topic.count > 0 ? plain(topic.last) : undefined,
      series: seriesTopics.has(topic.name) ? topic.records : undefined,
    };
  }
  await filelike.close();
  return out;
}

async function main() {
  const args = process.argv.slice(2);
  let file;
  const series = new Set();
  for (let i = 0; i < args.length; ++i) {
    if (args[i] === "--series") {
      if (i + 1 >= args.length) usage("--series: missing topic");
      series.add(args[++i]);
    } else if (args[i] === "--help" || args[i] === "-h") {
      usage("help");
    } else if (file === undefined) {
      file = args[i];
    } else {
      usage(`unexpected argument '${args[i]}'`);
    }
  }
  if (file === undefined) usage("no file given");
  if (!fs.existsSync(file)) {
    process.stderr.write(`ulog_check: ${file}: no such file\n`);
    process.exit(1);
  }
  try {
    const out = await check(file, series);
    process.stdout.write(JSON.stringify(out, null, 1) + "\n");
  } catch (e) {
    const text = String(e && e.message ? e.message : e);
    process.stderr.write(`ulog_check: ${text.startsWith(file) ? text : `${file}: ${text}`}\n`);
    process.exit(1);
  }
}

main();
