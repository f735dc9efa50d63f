// node-mavlink's side of tests/firmware/test_radio_signing.cpp: prints, one per line as "NAME HEX",
//   setup      SETUP_SIGNING (unsigned) with the key of PASSPHRASE and a start timestamp 10 s before T,
//   arm        COMMAND_LONG arm, signed by node-mavlink with that key at time T (link id 3),
//   arm_wrong  the same command signed with another passphrase's key.
// Usage: node signing_peer.js PASSPHRASE   (NODE_PATH must reach node-mavlink's node_modules)
'use strict';

const { common, MavLinkProtocolV2, MavLinkPacketSignature } = require('node-mavlink');

const passphrase = process.argv[2];
const key = MavLinkPacketSignature.key(passphrase);
const t = Date.UTC(2026, 0, 1);

const setup = new common.SetupSigning();
setup.targetSystem = 1;
setup.targetComponent = 1;
setup.secretKey = Array.from(key);
setup.initialTimestamp = BigInt((t - MavLinkProtocolV2.SIGNATURE_START_TIME) * 100 - 1000000);
const plain = new MavLinkProtocolV2(255, 190);
console.log(`setup ${plain.serialize(setup, 11).toString('hex')}`);

const arm = new common.CommandLong();
arm.targetSystem = 1;
arm.targetComponent = 1;
arm.command = common.MavCmd.COMPONENT_ARM_DISARM;
arm._param1 = 1;  // node-mavlink names COMMAND_LONG's param1 field '_param1'
const signed = new MavLinkProtocolV2(255, 190, MavLinkProtocolV2.IFLAG_SIGNED);
console.log(`arm ${signed.sign(signed.serialize(arm, 12), 3, key, t).toString('hex')}`);
const wrong = MavLinkPacketSignature.key(`${passphrase} (not)`);
console.log(`arm_wrong ${signed.sign(signed.serialize(arm, 13), 3, wrong, t + 10).toString('hex')}`);
