// Cycle cost of the link codec on the ATmega2560 (APM 2.5), run on simavr by tools/avr_cycles: what one
// HIL step costs the flight board (parse and decode HIL_SENSOR, encode HIL_ACTUATOR_CONTROLS), and the
// cost per byte of noise; what message signing adds (SHA-256 of one block, signing and verifying the
// HIL_SENSOR frame); and the AVR's CRC and SHA-256 against references. Built with avr-g++ and the avr-apm25 preset's flags by tests/link/CMakeLists.txt.
#include "cycle_probe.h"
#include "quad/link/mavlink.h"

namespace mav = quad::mavlink;

namespace {

volatile float g_in[3] = {0.12f, -0.07f, -9.81f};  // values the compiler cannot fold
uint8_t g_frame[mav::max_frame_length<mav::HilSensor>()];
uint8_t g_out[mav::max_frame_length<mav::HilActuatorControls>()];
uint8_t g_noise[100];
uint8_t g_signed[mav::max_frame_length<mav::HilSensor>(true)];
mav::Parser g_parser;
mav::SigningKey g_key;

template <typename F>
void measure(const char* name, F&& f) {
  quad_probe::name(name);
  quad_probe::start();
  f();
  quad_probe::stop();
}

}  // namespace

int main() {
  mav::Sender sender(1, 200);
  mav::HilSensor sample;
  sample.time_usec = 123456789;
  sample.xacc = g_in[0];
  sample.yacc = g_in[1];
  sample.zacc = g_in[2];
  sample.xgyro = 0.001f;
  sample.ygyro = -0.002f;
  sample.zgyro = 0.0005f;
  sample.xmag = 0.21f;
  sample.ymag = 0.01f;
  sample.zmag = 0.43f;
  sample.fields_updated = 0x1FF;
  for (uint8_t i = 0; i < sizeof g_noise; ++i) g_noise[i] = static_cast<uint8_t>(i * 7 + 1);  // no 0xFD

  size_t size = 0;
  int frames = 0;
  mav::HilSensor decoded;
  measure("overhead", [] {});
  measure("encode_hil_sensor", [&] { size = sender.encode(sample, g_frame, sizeof g_frame); });
  quad_probe::keep(size);
  measure("parse_hil_sensor_frame", [&] {
    for (size_t i = 0; i < size; ++i) g_parser.feed(g_frame[i], [&](const mav::Frame&) { ++frames; });
  });
  measure("decode_hil_sensor", [&] { frames += mav::decode(g_parser.frame(), decoded) ? 1 : 0; });
  quad_probe::keep(decoded);

  mav::HilActuatorControls out;
  out.time_usec = decoded.time_usec;
  out.controls[0] = g_in[0];
  out.controls[1] = 0.51f;
  out.controls[2] = 0.49f;
  out.controls[3] = 0.5f;
  out.mode = mav::kModeFlagSafetyArmed;
  out.flags = mav::kHilActuatorControlsFlagLockstep;
  measure("encode_hil_actuator_controls", [&] { size = sender.encode(out, g_out, sizeof g_out); });
  quad_probe::keep(size);
  measure("parse_100_noise_bytes", [&] {
    for (uint8_t b : g_noise) g_parser.feed(b, [&](const mav::Frame&) { ++frames; });
  });

  // Signing: the frame sent on a signed link, then the receiver's check of it.
  for (uint8_t i = 0; i < sizeof g_key.bytes; ++i) g_key.bytes[i] = static_cast<uint8_t>(i);
  mav::SigningClock ground_clock(34715520000000ull);
  mav::SigningClock vehicle_clock(34715520000000ull);
  mav::Signer signer(g_key, ground_clock, 1);
  mav::SignatureVerifier verifier(g_key, vehicle_clock);
  verifier.set_require_signed(true);
  uint8_t digest[mav::kSha256DigestLength];
  measure("sha256_abc", [&] { mav::sha256(reinterpret_cast<const uint8_t*>("abc"), 3, digest); });
  quad_probe::keep(digest);
  measure("sign_hil_sensor", [&] { size = mav::encode_signed(sender, signer, sample, g_signed, sizeof g_signed); });
  quad_probe::keep(size);
  int verified = 0;
  for (size_t i = 0; i < size; ++i) {
    if (g_parser.push(g_signed[i])) {
      measure("verify_hil_sensor", [&] { verified += mav::accepted(verifier.check(g_parser.frame())) ? 1 : 0; });
      while (g_parser.next()) {
      }
    }
  }
  // FIPS 180-4's "abc" example: the AVR's SHA-256 (flash constants, 8-bit arithmetic) is right.
  static const uint8_t kAbcDigest[] = {0xba, 0x78, 0x16, 0xbf, 0x8f, 0x01, 0xcf, 0xea};
  bool sha_ok = true;
  for (uint8_t i = 0; i < sizeof kAbcDigest; ++i) sha_ok = sha_ok && digest[i] == kAbcDigest[i];
  // A replay of the same frame must be rejected on the AVR too.
  for (size_t i = 0; i < size; ++i) {
    g_parser.feed(g_signed[i], [&](const mav::Frame& f) { verified += verifier.check(f) == mav::SignatureCheck::kRejectedReplay ? 1 : 0; });
  }

  // The AVR computes the CRC with avr-libc's assembly: check it against references made elsewhere, the
  // CRC-16/MCRF4XX check value and a HEARTBEAT frame serialised by node-mavlink.
  static const uint8_t kDigits[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  static const uint8_t kNodeHeartbeat[] = {0xfd, 0x09, 0x00, 0x00, 0x07, 0x01, 0x01, 0x00, 0x00, 0x00, 0x04,
                                           0x03, 0x02, 0x01, 0x02, 0x00, 0x81, 0x04, 0x03, 0x31, 0xbb};
  const bool crc_ok = mav::crc_accumulate(kDigits, sizeof kDigits, mav::kCrcInit) == 0x6F91;
  mav::Heartbeat heartbeat;
  for (uint8_t b : kNodeHeartbeat) {
    g_parser.feed(b, [&](const mav::Frame& f) { frames += mav::decode(f, heartbeat) ? 1 : 0; });
  }

  // A lost or wrongly decoded frame makes the ctest fail (FAIL_REGULAR_EXPRESSION "ERROR_").
  const bool ok = crc_ok && sha_ok && verified == 2 && frames == 3 && decoded.zacc == sample.zacc && decoded.fields_updated == 0x1FF &&
                  heartbeat.custom_mode == 0x01020304 && heartbeat.base_mode == 0x81;
  measure(ok ? "frames_ok" : "ERROR_frame_lost_or_wrong", [] {});
  quad_probe::done();
  for (;;) {
  }
}
