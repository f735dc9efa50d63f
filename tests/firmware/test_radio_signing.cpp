// The signed radio link end to end, in MAVLink bytes: key provisioning over USB only, rejection and
// counting of unsigned, wrongly signed and replayed frames on the radio, signed telemetry, the key and
// the signing clock across reboots, and the radio closed when SIGN_ENABLE is set without a key.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "app_bench.h"
#include "quad/link/dialect.h"
#include "quad/firmware/storage_layout.h"
#include "quad/link/sha256.h"

namespace {

using quad::fw::test::Bench;
namespace mav = quad::mavlink;
using quad::fw::FlightMode;
using quad::mavlink::SetupSigning;
constexpr uint8_t kUsb = quad::hal::kUart0;
constexpr uint8_t kRadio = quad::hal::kUart2;

// A ground station's signing side: its key, clock and signer.
struct Signing {
  explicit Signing(uint8_t seed, uint64_t start = 400000000000ull) : clock(start), signer(key, clock, 7) {
    for (uint8_t i = 0; i < 32; ++i) key.bytes[i] = static_cast<uint8_t>(seed * 31 + i * 7 + 1);
  }
  mav::SigningKey key;
  mav::SigningClock clock;
  mav::Signer signer;
};

void calibrate(Bench& b) {
  for (int i = 0; i < 250 && !b.app->calibrated(); ++i) b.still_step();
  ASSERT_TRUE(b.app->calibrated());
  // The pre-arm check: the ground hold brings the position filter's variances under its thresholds.
  quad::fw::test::ready_to_arm(b);
}

SetupSigning setup_message(const Signing& s) {
  SetupSigning m;
  m.target_system = 1;
  m.target_component = 1;
  m.initial_timestamp = s.clock.now();
  std::memcpy(m.secret_key, s.key.bytes, 32);
  return m;
}

void set_param(Bench& b, uint8_t port, const char* name, float value, Signing* signing = nullptr) {
  mav::ParamSet set;
  set.target_system = 1;
  std::strncpy(set.param_id, name, 16);
  set.param_value = value;
  if (signing != nullptr) b.send_signed(port, set, b.gcs, signing->signer);
  else b.send(port, set, b.gcs);
}

mav::CommandLong arm_command() {
  mav::CommandLong c;
  c.command = mav::kCmdComponentArmDisarm;
  c.param1 = 1.0f;
  c.target_system = 1;
  c.target_component = 1;
  return c;
}

// Boots, provisions `owner`'s key over USB, turns signing on, calibrates, RC sticks down.
void provisioned_vehicle(Bench& b, Signing& owner) {
  b.boot();
  b.send(kUsb, setup_message(owner), b.gcs);
  ASSERT_TRUE(b.said("signing: key set"));
  set_param(b, kUsb, "SIGN_ENABLE", 1.0f);
  ASSERT_TRUE(b.app->radio_signing().active());
  calibrate(b);
  b.sticks(0);
}

TEST(RadioSigning, RejectsUnsignedWrongKeyAndReplayedFramesAndCountsThem) {
  Bench b;
  Signing owner(1), stranger(2);
  provisioned_vehicle(b, owner);
  const size_t acks_before = b.acks.size();

  // Unsigned arm over the radio: rejected before it reaches the command handler.
  b.send(kRadio, arm_command(), b.gcs);
  // Signed with another key.
  b.send_signed(kRadio, arm_command(), b.gcs, stranger.signer);
  EXPECT_EQ(b.acks.size(), acks_before) << "rejected frames get no answer";
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);

  // Signed with the owner's key: armed.
  const std::vector<uint8_t> accepted = b.send_signed(kRadio, arm_command(), b.gcs, owner.signer);
  ASSERT_EQ(b.acks.size(), acks_before + 1);
  EXPECT_EQ(b.acks.back().result, mav::kResultAccepted);
  EXPECT_EQ(b.app->mode(), FlightMode::kManual);

  // Disarm, then replay the recorded arm frame byte for byte: rejected, the vehicle stays disarmed.
  mav::CommandLong disarm = arm_command();
  disarm.param1 = 0.0f;
  b.send_signed(kRadio, disarm, b.gcs, owner.signer);
  ASSERT_EQ(b.app->mode(), FlightMode::kDisarmed);
  b.receive_bytes(kRadio, accepted);
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed) << "a replayed arm must not arm";

  const quad::fw::RadioSigningStats st = b.app->radio_signing().stats();
  EXPECT_EQ(st.verifier.rejected_unsigned, 1u);
  EXPECT_EQ(st.verifier.bad_signature, 1u);
  EXPECT_EQ(st.verifier.replayed, 1u);
  EXPECT_EQ(st.rejected(), 3u);
  EXPECT_EQ(st.verifier.accepted_signed, 2u);
  std::printf("radio frames rejected: unsigned %u, wrong key %u, replayed %u; accepted signed %u\n",
              st.verifier.rejected_unsigned, st.verifier.bad_signature, st.verifier.replayed, st.verifier.accepted_signed);

  // Reported: SYS_STATUS errors_count4 and one STATUSTEXT.
  for (int i = 0; i < 110; ++i) b.still_step();
  ASSERT_FALSE(b.statuses.empty());
  EXPECT_EQ(b.statuses.back().errors_count4, 3u);
  EXPECT_TRUE(b.said("signing: radio frames rejected"));
}

TEST(RadioSigning, UsbNeedsNoSignatureAndSignedFramesAreNotRequiredWhenDisabled) {
  Bench b;
  Signing owner(1);
  b.boot();
  b.send(kUsb, setup_message(owner), b.gcs);
  calibrate(b);
  b.sticks(0);
  // SIGN_ENABLE 0: unsigned radio frames pass, but a wrongly signed one is still rejected.
  Signing stranger(2);
  mav::CommandLong disarm = arm_command();
  disarm.param1 = 0.0f;
  b.send_signed(kRadio, arm_command(), b.gcs, stranger.signer);
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);
  b.send(kRadio, arm_command(), b.gcs);
  EXPECT_EQ(b.app->mode(), FlightMode::kManual);
  b.send(kRadio, disarm, b.gcs);
  // SIGN_ENABLE 1: the USB port still takes unsigned commands (the HIL link and the provisioning cable).
  set_param(b, kUsb, "SIGN_ENABLE", 1.0f);
  EXPECT_EQ(b.arm(), mav::kResultAccepted);
}

TEST(RadioSigning, TelemetryOnTheRadioIsSignedWithTheKeyAndUsbIsNot) {
  Bench b;
  Signing owner(1);
  provisioned_vehicle(b, owner);
  mav::SigningClock gcs_clock(owner.clock.now());
  mav::SignatureVerifier gcs(owner.key, gcs_clock);
  gcs.set_require_signed(true);
  b.radio_verifier = &gcs;
  const int radio_before = b.frames_on[kRadio];
  const int usb_signed_before = b.signed_frames_on[kUsb];
  for (int i = 0; i < 200; ++i) b.still_step();
  const int radio_frames = b.frames_on[kRadio] - radio_before;
  ASSERT_GT(radio_frames, 40) << "heartbeat, attitude, position, status for 2 s";
  EXPECT_EQ(gcs.stats().accepted_signed, static_cast<uint32_t>(radio_frames));
  EXPECT_EQ(gcs.stats().rejected(), 0u) << "each frame signed, timestamps strictly increasing";
  EXPECT_EQ(b.signed_frames_on[kUsb], usb_signed_before) << "the HIL link is not signed";
}

TEST(RadioSigning, ProvisioningOverTheRadioIsRefusedEvenWhenSigned) {
  Bench b;
  Signing owner(1), stranger(2);
  provisioned_vehicle(b, owner);
  // The key holder tries to change the key over the air; the stranger tries unsigned.
  b.send_signed(kRadio, setup_message(stranger), b.gcs, owner.signer);
  EXPECT_TRUE(b.said("signing: key refused on radio"));
  b.send(kRadio, setup_message(stranger), b.gcs);
  const quad::fw::RadioSigningStats st = b.app->radio_signing().stats();
  EXPECT_EQ(st.provisioning_refused, 1u) << "the signed attempt reached the handler and was refused";
  EXPECT_EQ(st.verifier.rejected_unsigned, 1u) << "the unsigned one never got that far";
  // The owner's key still rules.
  b.send_signed(kRadio, arm_command(), b.gcs, stranger.signer);
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);
  b.send_signed(kRadio, arm_command(), b.gcs, owner.signer);
  EXPECT_EQ(b.app->mode(), FlightMode::kManual);
}

TEST(RadioSigning, KeyAndClockSurviveARebootAndTheClockNeverGoesBack) {
  Bench b;
  Signing owner(1);
  provisioned_vehicle(b, owner);
  // Traffic moves the vehicle's clock; a disarm stores it.
  b.send_signed(kRadio, arm_command(), b.gcs, owner.signer);
  for (int i = 0; i < 50; ++i) b.still_step();
  mav::CommandLong disarm = arm_command();
  disarm.param1 = 0.0f;
  b.send_signed(kRadio, disarm, b.gcs, owner.signer);
  ASSERT_EQ(b.app->mode(), FlightMode::kDisarmed);
  for (int i = 0; i < 20; ++i) b.still_step();
  const uint64_t before = b.app->radio_signing().clock();
  EXPECT_GE(b.app->radio_signing().stats().clock_saves, 2u) << "at provisioning and at the disarm";

  b.boot();  // same storage, new RAM
  EXPECT_TRUE(b.app->radio_signing().has_key());
  EXPECT_TRUE(b.app->radio_signing().active());
  EXPECT_GT(b.app->radio_signing().clock(), before) << "jumped ahead of everything used before the reboot";
  EXPECT_LE(b.app->radio_signing().clock(), before + quad::fw::RadioSigning::kBootJump);
  calibrate(b);
  b.sticks(0);
  b.send_signed(kRadio, arm_command(), b.gcs, owner.signer);
  EXPECT_EQ(b.app->mode(), FlightMode::kManual) << "the stored key still verifies";
}

TEST(RadioSigning, RemovingTheKeyOverUsbAndEnableWithoutKeyClosesTheRadio) {
  Bench b;
  Signing owner(1);
  provisioned_vehicle(b, owner);
  SetupSigning off;
  off.target_system = 1;  // zero key, zero timestamp: MAVLink's "signing off"
  b.send(kUsb, off, b.gcs);
  EXPECT_TRUE(b.said("signing: key removed"));
  EXPECT_FALSE(b.app->radio_signing().has_key());
  // SIGN_ENABLE is still 1: nothing on the radio is accepted, signed or not.
  b.send(kRadio, arm_command(), b.gcs);
  b.send_signed(kRadio, arm_command(), b.gcs, owner.signer);
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);
  EXPECT_EQ(b.app->radio_signing().stats().rejected_no_key, 2u);
  // rejected() (SYS_STATUS errors_count4) is stats().rejected(): the no-key rejections counted too.
  EXPECT_EQ(b.app->radio_signing().rejected(), b.app->radio_signing().stats().rejected());
  EXPECT_GE(b.app->radio_signing().rejected(), 2u);
  b.boot();
  EXPECT_TRUE(b.said("signing: no key, radio closed"));
}

// Frames made by node-mavlink (tests/firmware/signing_peer.js): NAME -> bytes.
std::map<std::string, std::vector<uint8_t>> node_frames(const std::string& passphrase) {
  const std::string cmd = std::string("NODE_PATH='") + QUAD_NODE_DIR + "/node_modules' '" + QUAD_NODE_EXECUTABLE + "' '" +
                          QUAD_FIRMWARE_TEST_DIR + "/signing_peer.js' '" + passphrase + "'";
  std::map<std::string, std::vector<uint8_t>> frames;
  FILE* p = popen(cmd.c_str(), "r");
  if (p == nullptr) return frames;
  char name[32];
  char hex[1024];
  while (std::fscanf(p, "%31s %1023s", name, hex) == 2) {
    std::vector<uint8_t> bytes;
    for (size_t i = 0; hex[i] != '\0' && hex[i + 1] != '\0'; i += 2) {
      bytes.push_back(static_cast<uint8_t>(std::stoi(std::string(hex + i, 2), nullptr, 16)));
    }
    frames[name] = bytes;
  }
  pclose(p);
  return frames;
}

TEST(RadioSigning, NodeMavlinkSetupSigningAndSignedCommandsAreUnderstood) {
  const std::string passphrase = "correct horse battery staple";
  auto frames = node_frames(passphrase);
  ASSERT_EQ(frames.size(), 3u) << "node or node-mavlink missing (make setup)";

  // SETUP_SIGNING: node-mavlink's id, CRC_EXTRA and layout agree with ours (the CRC would fail otherwise).
  mav::Parser parser(quad::mavlink::dialect_message_info);
  SetupSigning decoded;
  int got = 0;
  parser.feed(frames["setup"].data(), frames["setup"].size(), [&](const mav::Frame& f) {
    got += mav::decode(f, decoded) ? 1 : 0;
  });
  ASSERT_EQ(got, 1);
  uint8_t key[32];
  quad::mavlink::sha256(reinterpret_cast<const uint8_t*>(passphrase.data()), passphrase.size(), key);
  EXPECT_EQ(std::memcmp(decoded.secret_key, key, 32), 0) << "node-mavlink's key = SHA-256(passphrase), as quad_gs";
  EXPECT_EQ(decoded.target_system, 1);
  EXPECT_EQ(decoded.target_component, 1);
  EXPECT_EQ(decoded.initial_timestamp, (1767225600000ull - 1420070400000ull) * 100ull - 1000000ull);

  // The vehicle takes node-mavlink's provisioning over USB and its signed arm over the radio.
  Bench b;
  b.boot();
  b.receive_bytes(kUsb, frames["setup"]);
  ASSERT_TRUE(b.said("signing: key set"));
  set_param(b, kUsb, "SIGN_ENABLE", 1.0f);
  calibrate(b);
  b.sticks(0);
  b.receive_bytes(kRadio, frames["arm_wrong"]);
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);
  b.receive_bytes(kRadio, frames["arm"]);
  EXPECT_EQ(b.app->mode(), FlightMode::kManual);
  const quad::fw::RadioSigningStats st = b.app->radio_signing().stats();
  EXPECT_EQ(st.verifier.bad_signature, 1u);
  EXPECT_EQ(st.verifier.accepted_signed, 1u);
  // And node-mavlink's frame replayed: rejected.
  b.receive_bytes(kRadio, frames["arm"]);
  EXPECT_EQ(b.app->radio_signing().stats().verifier.replayed, 1u);
  // rejected(): the bad signature and the replay, the verifier's counts summed as stats().rejected().
  EXPECT_EQ(b.app->radio_signing().rejected(), b.app->radio_signing().stats().rejected());
  EXPECT_EQ(b.app->radio_signing().rejected(), 2u);
}

TEST(RadioSigning, KeyRecordFitsWithTheParametersInTheEeprom) {
  EXPECT_LE(quad::fw::kStorageUsed, 1024u) << "params, key and clock, two copies each";
}

}  // namespace
