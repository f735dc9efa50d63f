// Cost of the flight application on the host: one whole HIL step (HIL_SENSOR parsed, estimation, AUTO
// position control, mixing, telemetry, HIL_ACTUATOR_CONTROLS encoded) and the same with one extra vision
// fix each (LANDING_TARGET parsed, attitude looked up at capture time, delayed Kalman update); and the
// first with the radio signed (SIGN_ENABLE 1: the fixes verified, the radio telemetry signed).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstring>
#include <memory>
#include <vector>

#include "quad/firmware/app.h"
#include "quad/firmware/hil_bridge.h"
#include "quad/link/dialect.h"
#include "quad/link/signing.h"

namespace {

namespace mav = quad::mavlink;

std::vector<uint8_t> g_storage(4096, 0xFF);
uint64_t g_t_us = 1000000;
size_t g_sent = 0;

bool storage_read(uint16_t offset, void* dst, uint16_t length) {
  std::memcpy(dst, g_storage.data() + offset, length);
  return true;
}
bool storage_write(uint16_t offset, const void* src, uint16_t length) {
  std::memcpy(g_storage.data() + offset, src, length);
  return true;
}
uint16_t write_port(uint8_t, const uint8_t*, uint16_t length) {
  g_sent += length;
  return length;
}
uint32_t micros() { return static_cast<uint32_t>(g_t_us); }

template <class Msg>
std::vector<uint8_t> frame(const Msg& msg, mav::Sender& sender) {
  std::vector<uint8_t> buf(mav::max_frame_length<Msg>());
  buf.resize(sender.encode(msg, buf.data(), buf.size()));
  return buf;
}

struct Flying {
  std::unique_ptr<quad::fw::FlightApp> app = std::make_unique<quad::fw::FlightApp>();
  quad::fw::HilBridge bridge;
  mav::Sender sim{1, 200}, gcs{255, 190}, vision{1, 197};
  mav::SigningKey key{};
  mav::SigningClock clock{400000000000ull};
  mav::Signer signer{key, clock, 5};
  bool signed_radio;

  explicit Flying(bool sign = false) : signed_radio(sign) {
    std::fill(g_storage.begin(), g_storage.end(), 0xFF);
    quad::fw::AppIo io;
    io.storage = quad::fw::StorageIo{storage_read, storage_write};
    io.write = write_port;
    io.micros = micros;
    bridge.connect(*app, io);
    app->init(io);
    mav::ParamSet set;
    set.target_system = 1;
    std::strncpy(set.param_id, "FS_RC_ENABLE", 16);
    feed(quad::hal::kUart0, frame(set, gcs));
    if (signed_radio) {
      mav::SetupSigning setup;
      setup.target_system = 1;
      setup.initial_timestamp = clock.now();
      for (uint8_t i = 0; i < 32; ++i) key.bytes[i] = setup.secret_key[i] = static_cast<uint8_t>(i * 13 + 5);
      feed(quad::hal::kUart0, frame(setup, gcs));
      std::strncpy(set.param_id, "SIGN_ENABLE", 16);
      set.param_value = 1.0f;
      feed(quad::hal::kUart0, frame(set, gcs));
    }
    for (int i = 0; i < 300; ++i) step(i);
    mav::CommandLong c;
    c.target_system = 1;
    c.command = mav::kCmdComponentArmDisarm;
    c.param1 = 1.0f;
    feed(quad::hal::kUart0, frame(c, gcs));
    c.command = mav::kCmdDoSetMode;
    c.param1 = 1.0f;
    c.param2 = 2.0f;  // AUTO
    feed(quad::hal::kUart0, frame(c, gcs));
  }
  void feed(uint8_t port, const std::vector<uint8_t>& bytes) {
    app->receive(port, bytes.data(), static_cast<uint16_t>(bytes.size()), static_cast<uint32_t>(g_t_us));
  }
  void step(int i) {
    mav::HilSensor s;
    s.time_usec = g_t_us;
    s.zacc = -9.80665f;
    s.xgyro = 0.001f * static_cast<float>(i % 7);
    s.xmag = 0.21f;
    s.zmag = 0.43f;
    s.fields_updated = 0x1FF;
    feed(quad::hal::kUart0, frame(s, sim));
    if (i % 3 == 0) fix(g_t_us - 30000);
    g_t_us += 10000;
  }
  void fix(uint64_t capture) {
    mav::LandingTarget lt;
    lt.time_usec = capture;
    lt.frame = mav::kFrameBodyFrd;
    lt.position_valid = 1;
    lt.z = 1.5f;
    if (!signed_radio) {
      feed(quad::hal::kUart2, frame(lt, vision));
      return;
    }
    std::vector<uint8_t> buf(mav::max_frame_length<mav::LandingTarget>(true));
    buf.resize(mav::encode_signed(vision, signer, lt, buf.data(), buf.size()));
    feed(quad::hal::kUart2, buf);
  }
};

// One 10 ms HIL step in AUTO: HIL_SENSOR encoded and parsed, the iteration, HIL_ACTUATOR_CONTROLS and
// the telemetry encoded; every third step also a LANDING_TARGET (30 Hz vision keeps AUTO going).
void BM_HilIteration(benchmark::State& state) {
  Flying f;
  int i = 0;
  for (auto _ : state) f.step(i++);
  state.counters["auto"] = f.app->mode() == quad::fw::FlightMode::kAuto ? 1.0 : 0.0;
}
BENCHMARK(BM_HilIteration);

void BM_HilIterationPlusFix(benchmark::State& state) {
  Flying f;
  int i = 1;
  for (auto _ : state) {
    f.step(i++);
    f.fix(g_t_us - 40000);
  }
  state.counters["auto"] = f.app->mode() == quad::fw::FlightMode::kAuto ? 1.0 : 0.0;
}
BENCHMARK(BM_HilIterationPlusFix);

// BM_HilIteration with SIGN_ENABLE 1: every third step a signed LANDING_TARGET verified (SHA-256 over
// key + frame), and the radio's telemetry (10 Hz attitude and position, 1 Hz heartbeat and status)
// signed. "rejected" must stay 0: every fix was accepted.
void BM_HilIterationSignedRadio(benchmark::State& state) {
  Flying f(true);
  int i = 0;
  for (auto _ : state) f.step(i++);
  state.counters["auto"] = f.app->mode() == quad::fw::FlightMode::kAuto ? 1.0 : 0.0;
  state.counters["rejected"] = f.app->radio_signing().stats().rejected();
  state.counters["signed_fixes"] = f.app->radio_signing().stats().verifier.accepted_signed;
}
BENCHMARK(BM_HilIterationSignedRadio);

}  // namespace

BENCHMARK_MAIN();
