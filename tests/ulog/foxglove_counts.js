#!/usr/bin/env node
// The field's reader (@foxglove/ulog) on a log: each topic's record count and the float bits of the
// fields of its first record, in ulog_dump's form ("topic NAME MULTI_ID COUNT", "first NAME: v v ..."),
// the info and the parameters at log start, for readers_agree.sh to compare with the project's readers.
//   node foxglove_counts.js LOG.ulg     (exit 1 when the library cannot read the log)
"use strict";
const { ULog } = require("@foxglove/ulog");
const { FileReader } = require("@foxglove/ulog/node");

function bits(type, v) {
  const view = new DataView(new ArrayBuffer(8));
  if (type === "float") { view.setFloat32(0, v, true); return view.getUint32(0, true).toString(16).padStart(8, "0"); }
  if (type === "double") { view.setFloat64(0, v, true); return view.getBigUint64(0, true).toString(16).padStart(16, "0"); }
  return String(typeof v === "boolean" ? Number(v) : v);
}

// C's "%.9g".
function g9(x) {
  if (x === 0) return "0";
  const e = Math.floor(Math.log10(Math.abs(Number(x.toExponential(8)))));
  if (e < -4 || e >= 9) {
    const [m, ex] = x.toExponential(8).split("e");
    const mant = m.includes(".") ? m.replace(/\.?0+$/, "") : m;
    const n = Number(ex);
    return `${mant}e${n < 0 ? "-" : "+"}${String(Math.abs(n)).padStart(2, "0")}`;
  }
  const t = x.toPrecision(9);
  return t.includes(".") ? t.replace(/\.?0+$/, "") : t;
}

function fields(definitions, def, value, out) {
  for (const f of def.fields) {
    if (f.name.startsWith("_padding")) continue;
    const v = value[f.name];
    if (f.isComplex) {
      for (const item of f.arrayLength !== undefined ? v : [v]) fields(definitions, definitions.get(f.type), item, out);
    } else if (f.type === "char" && f.arrayLength !== undefined) {
      out.push(`"${v}"`);
    } else {
      for (const item of f.arrayLength !== undefined ? Array.from(v) : [v]) out.push(bits(f.type, item));
    }
  }
}

(async () => {
  const log = new ULog(new FileReader(process.argv[2]));
  await log.open();
  const defs = log.header.definitions;
  const lines = [];
  const counts = log.dataMessageCounts();
  for (const [id, sub] of log.subscriptions) {
    lines.push(`topic ${sub.name} ${sub.multiId} ${counts.get(id) ?? 0}`);
    for await (const msg of log.readMessages({ msgIds: new Set([id]), includeLogs: false })) {
      const out = [];
      fields(defs, defs.get(sub.name), msg.value, out);
      lines.push(`first ${sub.name}: ${out.join(" ")}`);
      break;
    }
  }
  for (const [k, v] of log.header.information) lines.push(`info ${k} ${v}`);
  for (const [k, p] of log.header.parameters) lines.push(`param ${k} ${g9(Number(p.value))}`);
  process.stdout.write(lines.sort().join("\n") + "\n");
})().catch((e) => { process.stderr.write(`foxglove_counts: ${e.message}\n`); process.exit(1); });
