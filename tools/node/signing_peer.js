#!/usr/bin/env node
// The real MAVLink signing peer for the signing test of the link codec (tests/link/test_signing_node.cpp):
// node-mavlink signs frames, and checks the signatures of ours.
//
//   node signing_peer.js sign KEY_HEX SEED COUNT START_MS OUT.bin OUT.txt
//       COUNT frames of random messages (those of mavlink_peer.js, random values) from system 1 or 2,
//       component 190, each signed by node-mavlink's MavLinkProtocolV2.sign() with the 32-byte key KEY_HEX,
//       a link id from {0, 1, 2} and the timestamp START_MS + i milliseconds (Unix time), so every
//       stream's timestamps increase.
//       OUT.txt gets one line per frame: SYSID COMPID LINKID TIMESTAMP (the 48-bit field, 10 µs units).
//   node signing_peer.js verify KEY_HEX IN.bin OUT.txt
//       splits and parses IN.bin with node-mavlink and checks each frame's signature with
//       MavLinkPacketSignature.matches(KEY): one line per frame, SYSID COMPID LINKID TIMESTAMP ok|bad,
//       or SYSID COMPID unsigned. Exits non-zero if the splitter rejected any frame (bad CRC, unknown id).
'use strict';

const fs = require('fs');
const { Readable } = require('stream');
const { MavLinkProtocolV2, MavLinkPacketSplitter, MavLinkPacketParser } = require('node-mavlink');
const { REGISTRY, MESSAGES, classByName, wireFields, makeRandom, randomValue } = require('./mavlink_peer.js');

function parseKey(hex) {
  const key = Buffer.from(hex, 'hex');
  if (key.length !== 32) throw new Error(`the key must be 64 hex digits, got '${hex}'`);
  return key;
}

function sign(keyHex, seed, count, startMs, binPath, textPath) {
  const key = parseKey(keyHex);
  const random = makeRandom(seed);
  const frames = [];
  const lines = [];
  for (let i = 0; i < count; i++) {
    const clazz = classByName(MESSAGES[random.below(MESSAGES.length)]);
    const message = new clazz();
    for (const field of wireFields(clazz)) message[field.name] = randomValue(field, random, false);
    // Six streams (system id 1 or 2, link id 0..2), within the verifier's table of eight.
    const sysid = 1 + random.below(2);
    const compid = 190;
    const linkId = random.below(3);
    const protocol = new MavLinkProtocolV2(sysid, compid, MavLinkProtocolV2.IFLAG_SIGNED);
    const frame = protocol.sign(protocol.serialize(message, i & 0xff), linkId, key, startMs + i);
    const block = frame.subarray(frame.length - 13);
    frames.push(frame);
    lines.push(`${sysid} ${compid} ${block.readUInt8(0)} ${block.readUIntLE(1, 6)}`);
  }
  fs.writeFileSync(binPath, Buffer.concat(frames));
  fs.writeFileSync(textPath, lines.join('\n') + '\n');
}

function verify(keyHex, binPath, textPath) {
  const key = parseKey(keyHex);
  const splitter = new MavLinkPacketSplitter();
  const lines = [];
  const reader = Readable.from([fs.readFileSync(binPath)]).pipe(splitter).pipe(new MavLinkPacketParser());
  reader.on('data', (packet) => {
    const { sysid, compid, msgid } = packet.header;
    if (!REGISTRY[msgid]) throw new Error(`unknown message id ${msgid}`);
    if (!packet.signature) {
      lines.push(`${sysid} ${compid} unsigned`);
      return;
    }
    const s = packet.signature;
    lines.push(`${sysid} ${compid} ${s.linkId} ${s.timestamp} ${s.matches(key) ? 'ok' : 'bad'}`);
  });
  reader.on('end', () => {
    fs.writeFileSync(textPath, lines.join('\n') + (lines.length ? '\n' : ''));
    if (splitter.invalidPackages || splitter.unknownPackagesCount) {
      console.error(`node-mavlink rejected frames: ${splitter.invalidPackages} invalid, ` +
        `${splitter.unknownPackagesCount} unknown`);
      process.exitCode = 1;
    }
  });
}

function main(argv) {
  const [mode, ...args] = argv;
  if (mode === 'sign' && args.length === 6) {
    sign(args[0], Number(args[1]), Number(args[2]), Number(args[3]), args[4], args[5]);
  } else if (mode === 'verify' && args.length === 3) {
    verify(args[0], args[1], args[2]);
  } else {
    console.error('usage: signing_peer.js sign KEY_HEX SEED COUNT START_MS OUT.bin OUT.txt | ' +
      'verify KEY_HEX IN.bin OUT.txt');
    process.exitCode = 2;
  }
}

main(process.argv.slice(2));
