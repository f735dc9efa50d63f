// Telemetry of the flight application (docs/firmware.md "Telemetry"): what SYS_STATUS carries (the loop
// load, loop overruns, frames with a bad CRC and sequence gaps on the links) and that the configured
// message rates are the rates sent.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstring>
#include <vector>

#include "app_bench.h"
#include "quad/firmware/app.h"

namespace {

using quad::fw::test::Bench;
namespace mav = quad::mavlink;
using quad::fw::FlightMode;

// Counts the frames the test feeds the firmware that its parsers must accept, and remembers that count
// at each SYS_STATUS (sent in the middle of an iteration, after that iteration's HIL_SENSOR).
struct Feed {
  explicit Feed(Bench& bench) : b(bench) {}
  void step() {
    const size_t before = b.statuses.size();
    b.still_step();
    ++accepted;
    if (b.statuses.size() != before) accepted_at_status = accepted;
  }
  void steps(int n) {
    for (int i = 0; i < n; ++i) step();
  }
  void sticks() {
    b.sticks(0);
    ++accepted;
  }
  void vision_fix() {
    mav::VisionPositionEstimate v;
    v.usec = b.t_us - 20000;
    b.send(quad::hal::kUart2, v, b.vision);
    ++accepted;
  }
  // A frame from `from` whose CRC is broken: it uses up one of the sender's sequence numbers.
  template <class Msg>
  void corrupted(uint8_t port, const Msg& msg, mav::Sender& from) {
    uint8_t buf[mav::max_frame_length<Msg>()];
    const size_t n = from.encode(msg, buf, sizeof buf);
    ASSERT_GT(n, 12u);
    buf[n - 2] ^= 0x5A;  // CRC low byte
    // Only its own start byte may look like one, so the parser's rescan of the rejected bytes finds no
    // second (false) candidate to count.
    for (size_t i = 1; i < n; ++i) ASSERT_NE(buf[i], mav::kStx) << "byte " << i;
    b.receive_bytes(port, std::vector<uint8_t>(buf, buf + n));
  }
  Bench& b;
  int accepted = 0;
  int accepted_at_status = 0;
};

void calibrate(Feed& f) {
  for (int i = 0; i < 250 && !f.b.app->calibrated(); ++i) f.step();
  ASSERT_TRUE(f.b.app->calibrated());
  // The pre-arm check: the ground hold brings the position filter's variances under its thresholds.
  for (int i = 0; i < 100 && f.b.app->estimator().preflight() != quad::fw::Preflight::kReady; ++i) f.step();
  ASSERT_EQ(f.b.app->estimator().preflight(), quad::fw::Preflight::kReady);
}

TEST(Telemetry, SysStatusCarriesTheLoopLoadAndTheOverruns) {
  Bench b;
  b.boot();
  Feed f(b);
  calibrate(f);
  f.steps(150);
  ASSERT_FALSE(b.statuses.empty());
  EXPECT_EQ(b.statuses.back().load, 0) << "iterations that take no time";
  EXPECT_EQ(b.statuses.back().errors_count1, 0);

  // Iterations of 2.5 ms in the 10 ms period (SYS_LOOP_HZ 100): 250 per mille once the ~1 s filter
  // has settled (7 s: within 0.1 %).
  b.exec_us = 2500;
  f.steps(700);
  EXPECT_NEAR(b.statuses.back().load, 250, 1);
  EXPECT_EQ(b.statuses.back().errors_count1, 0) << "no overrun at a quarter of the period";
  // A whole period is still not an overrun; 7 iterations of 12 ms are 7 overruns.
  b.exec_us = 10000;
  f.steps(3);
  b.exec_us = 12000;
  f.steps(7);
  b.exec_us = 2500;
  f.steps(250);
  EXPECT_EQ(b.statuses.back().errors_count1, 7);
  EXPECT_EQ(b.app->loop_timer().overruns(), 7u);
  // At 3 ms of 5 ms (SYS_LOOP_HZ 200) the load is 600 per mille: a share of the configured period.
  ASSERT_EQ(b.app->override_param(quad::fw::kLoopHz, 200.0f), nullptr);
  b.exec_us = 3000;
  f.steps(1000);
  EXPECT_NEAR(b.statuses.back().load, 600, 1);
  EXPECT_EQ(b.statuses.back().errors_count1, 7);
}

// The loop's budget is its period: the first iteration in flight that takes longer is reported once
// (WARNING, with its time and the period), while boot and the ground may overrun unannounced; the
// longest iteration is kept beside the count.
TEST(Telemetry, TheFirstOverrunInFlightIsReportedOnceWithItsTime) {
  Bench b;
  b.boot();
  Feed f(b);
  calibrate(f);
  const auto overrun_texts = [&] {
    std::vector<std::pair<uint8_t, std::string>> out;
    for (const auto& t : b.statustexts) {
      if (t.second.find("overrun") != std::string::npos) out.push_back(t);
    }
    return out;
  };
  b.exec_us = 15000;  // on the ground: counted, not announced
  f.steps(2);
  EXPECT_EQ(b.app->loop_timer().overruns(), 2u);
  EXPECT_TRUE(overrun_texts().empty());

  b.exec_us = 2000;
  f.sticks();
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  f.steps(20);
  ASSERT_TRUE(b.app->armed());
  b.exec_us = 10000;  // the whole period is within budget
  f.steps(5);
  EXPECT_TRUE(overrun_texts().empty());
  b.exec_us = 10400;
  f.step();
  b.exec_us = 13000;
  f.steps(4);
  b.exec_us = 2000;
  f.steps(150);
  ASSERT_EQ(overrun_texts().size(), 1u) << "once per flight";
  EXPECT_EQ(overrun_texts()[0].first, mav::kSeverityWarning);
  EXPECT_EQ(overrun_texts()[0].second, "loop overrun: 10400 us of a 10000 us period");
  EXPECT_EQ(b.app->loop_timer().overruns(), 7u);
  EXPECT_EQ(b.app->loop_timer().max_exec_us(), 15000u);
  EXPECT_EQ(b.statuses.back().errors_count1, 7);

  // Disarmed and armed again: a second flight is told of its own first overrun.
  ASSERT_EQ(b.command(mav::kCmdComponentArmDisarm, 0.0f), mav::kResultAccepted);
  f.steps(5);
  f.sticks();
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  f.steps(5);
  b.exec_us = 20000;
  f.step();
  ASSERT_EQ(overrun_texts().size(), 2u);
  EXPECT_EQ(overrun_texts()[1].second, "loop overrun: 20000 us of a 10000 us period");
}

TEST(Telemetry, SysStatusCountsBadFramesAndTheSequenceGapsTheyLeave) {
  Bench b;
  b.boot();
  Feed f(b);
  calibrate(f);
  for (int i = 0; i < 150; ++i) {
    f.step();
    if (i % 5 == 0) f.sticks();
    if (i % 3 == 0) f.vision_fix();
  }
  ASSERT_FALSE(b.statuses.empty());
  EXPECT_EQ(b.statuses.back().errors_comm, 0);
  EXPECT_EQ(b.statuses.back().drop_rate_comm, 0);

  // 6 MANUAL_CONTROL frames on UART0 and 4 VISION_POSITION_ESTIMATE frames on the radio arrive with a
  // broken CRC; each sender's next good frame shows the gap in its sequence.
  constexpr int kBadUart0 = 6, kBadRadio = 4;
  mav::ManualControl m;
  m.target = 1;
  m.z = 300;
  mav::VisionPositionEstimate v;
  v.x = 0.5f;
  for (int i = 0; i < kBadUart0; ++i) {
    f.corrupted(quad::hal::kUart0, m, b.gcs);
    f.steps(3);
    f.sticks();
    if (i < kBadRadio) {
      v.usec = b.t_us - 20000;
      f.corrupted(quad::hal::kUart2, v, b.vision);
      f.steps(2);
      f.vision_fix();
    }
    f.steps(5);
  }
  for (int i = 0; i < 150; ++i) {
    f.step();
    if (i % 5 == 0) f.sticks();
  }
  const mav::SysStatus& st = b.statuses.back();
  EXPECT_EQ(st.errors_comm, kBadUart0 + kBadRadio) << "bad CRC on both ports";
  constexpr int kLost = kBadUart0 + kBadRadio;
  const double expected = 10000.0 * kLost / (f.accepted_at_status + kLost);
  EXPECT_NEAR(st.drop_rate_comm, expected, 1.0) << "0.01 % of the frames: " << kLost << " lost of "
                                                << f.accepted_at_status + kLost;
  EXPECT_GT(st.drop_rate_comm, 0);
  std::printf("SYS_STATUS after %d bad frames in %d: errors_comm %u, drop_rate_comm %u (expected %.1f)\n", kLost,
              f.accepted_at_status + kLost, st.errors_comm, st.drop_rate_comm, expected);
}

TEST(Telemetry, ConfiguredRatesAreTheRatesSent) {
  Bench b;
  b.boot();
  Feed f(b);
  calibrate(f);
  // Set over the parameter protocol, as a ground station would.
  set_param_echoed(b, "TEL_ATT_HZ", 25.0f);
  set_param_echoed(b, "TEL_SYS_HZ", 5.0f);
  set_param_echoed(b, "TEL_HB_HZ", 2.0f);
  f.steps(7);  // out of phase with whole seconds
  int before[2][4];
  const uint32_t ids[4] = {mav::AttitudeQuaternion::kId, mav::LocalPositionNed::kId, mav::SysStatus::kId,
                           mav::Heartbeat::kId};
  for (uint8_t port = 0; port < 2; ++port) {
    for (int k = 0; k < 4; ++k) before[port][k] = b.count_on(port, ids[k]);
  }
  f.steps(400);  // 4 s
  const int expected[4] = {100, 40, 20, 8};  // 25 Hz, TEL_POS_HZ's default 10 Hz, 5 Hz, 2 Hz
  for (uint8_t port = 0; port < 2; ++port) {
    for (int k = 0; k < 4; ++k) {
      EXPECT_NEAR(b.count_on(port, ids[k]) - before[port][k], expected[k], 1) << "port " << int(port) << " message " << ids[k];
    }
  }
}

TEST(Telemetry, TheLandedStateOfEveryModeAndTheLandDetector) {
  using quad::fw::landed_state;
  EXPECT_EQ(landed_state(false, true, FlightMode::kDisarmed), mav::kLandedStateOnGround);
  EXPECT_EQ(landed_state(true, true, FlightMode::kManual), mav::kLandedStateOnGround);  // armed, not lifted
  EXPECT_EQ(landed_state(true, false, FlightMode::kManual), mav::kLandedStateInAir);
  EXPECT_EQ(landed_state(true, false, FlightMode::kAuto), mav::kLandedStateInAir);
  EXPECT_EQ(landed_state(true, false, FlightMode::kLanding), mav::kLandedStateLanding);
  EXPECT_EQ(landed_state(true, true, FlightMode::kLanding), mav::kLandedStateOnGround);  // touched down
}

TEST(Telemetry, ExtendedSysStateAtTheHeartbeatsRate) {
  Bench b;
  b.boot();
  Feed f(b);
  calibrate(f);
  const int hb_before = b.count_on(quad::hal::kUart0, mav::Heartbeat::kId);
  const size_t before = b.extended_states.size();
  f.steps(500);  // 5 s
  EXPECT_NEAR(static_cast<int>(b.extended_states.size() - before), 5, 1);
  EXPECT_EQ(b.count_on(quad::hal::kUart2, mav::ExtendedSysState::kId), b.count_on(quad::hal::kUart0, mav::ExtendedSysState::kId));
  EXPECT_EQ(b.count_on(quad::hal::kUart0, mav::Heartbeat::kId) - hb_before, static_cast<int>(b.extended_states.size() - before));
  ASSERT_FALSE(b.extended_states.empty());
  EXPECT_EQ(b.extended_states.back().landed_state, mav::kLandedStateOnGround);
  EXPECT_EQ(b.extended_states.back().vtol_state, mav::kVtolStateUndefined);
}

}  // namespace
