// Flight-mode state machine: every transition, every refusal and every failsafe of firmware/modes.h.
#include <gtest/gtest.h>

#include <vector>

#include "quad/firmware/modes.h"

namespace {

using quad::fw::Command;
using quad::fw::FlightMode;
using quad::fw::ModeInputs;
using quad::fw::ModeMachine;
using quad::fw::Reason;

constexpr uint32_t kSecond = 1000000u;

// A vehicle ready to fly: estimator converged and healthy, RC present with the throttle down, a
// fresh vision fix, on the ground.
ModeInputs ready(uint32_t now_us = 10 * kSecond) {
  ModeInputs in;
  in.now_us = now_us;
  in.estimator_converged = true;
  in.estimator_healthy = true;
  in.sensors_healthy = true;
  in.rc_seen = true;
  in.rc_time_us = now_us;
  in.rc_throttle = 0.0f;
  in.vision_seen = true;
  in.vision_time_us = now_us;
  in.landed = true;
  return in;
}

ModeMachine armed_in(FlightMode mode) {
  ModeMachine m;
  ModeInputs in = ready();
  EXPECT_TRUE(m.command(Command::kArm, in).changed);
  if (mode == FlightMode::kAuto || mode == FlightMode::kLanding) EXPECT_TRUE(m.command(Command::kAuto, in).changed);
  if (mode == FlightMode::kLanding) EXPECT_TRUE(m.command(Command::kLand, in).changed);
  EXPECT_EQ(m.mode(), mode);
  return m;
}

TEST(Modes, StartsDisarmed) {
  ModeMachine m;
  EXPECT_EQ(m.mode(), FlightMode::kDisarmed);
  EXPECT_FALSE(m.armed());
  EXPECT_FALSE(m.update(ready()).changed);
}

TEST(Modes, ArmGoesToManual) {
  ModeMachine m;
  const auto t = m.command(Command::kArm, ready());
  EXPECT_TRUE(t.accepted);
  EXPECT_TRUE(t.changed);
  EXPECT_EQ(t.from, FlightMode::kDisarmed);
  EXPECT_EQ(t.to, FlightMode::kManual);
  EXPECT_EQ(t.reason, Reason::kArmed);
  EXPECT_TRUE(m.armed());
}

TEST(Modes, ArmRefusedWithoutConvergedEstimator) {
  ModeMachine m;
  ModeInputs in = ready();
  in.estimator_converged = false;
  const auto t = m.command(Command::kArm, in);
  EXPECT_FALSE(t.accepted);
  EXPECT_EQ(t.reason, Reason::kRejectEstimatorNotConverged);
  EXPECT_EQ(m.mode(), FlightMode::kDisarmed);
}

TEST(Modes, ArmRefusedWithUnhealthySensors) {
  ModeMachine m;
  ModeInputs in = ready();
  in.sensors_healthy = false;
  EXPECT_EQ(m.command(Command::kArm, in).reason, Reason::kRejectSensors);
  EXPECT_FALSE(m.armed());
}

TEST(Modes, ArmRefusedWithThrottleUp) {
  ModeMachine m;
  ModeInputs in = ready();
  in.rc_throttle = 0.3f;
  EXPECT_EQ(m.command(Command::kArm, in).reason, Reason::kRejectThrottleHigh);
  in.rc_throttle = 0.05f;  // below ARM_THR_MAX (0.1)
  EXPECT_TRUE(m.command(Command::kArm, in).accepted);
}

TEST(Modes, ArmRefusedWithoutRcUnlessRcNotRequired) {
  ModeMachine m;
  ModeInputs in = ready();
  in.rc_seen = false;
  EXPECT_EQ(m.command(Command::kArm, in).reason, Reason::kRejectNoRc);
  in.rc_seen = true;
  in.rc_time_us = in.now_us - 2 * kSecond;  // stale
  EXPECT_EQ(m.command(Command::kArm, in).reason, Reason::kRejectNoRc);

  quad::fw::ModeConfig config;
  config.rc_required = false;
  ModeMachine no_rc(config);
  in.rc_seen = false;
  EXPECT_TRUE(no_rc.command(Command::kArm, in).accepted);
  // ... and without RC there is no RC failsafe.
  in.landed = false;
  EXPECT_FALSE(no_rc.update(in).changed);
  EXPECT_EQ(no_rc.mode(), FlightMode::kManual);
}

TEST(Modes, ArmWhenArmedIsRefused) {
  ModeMachine m = armed_in(FlightMode::kManual);
  EXPECT_EQ(m.command(Command::kArm, ready()).reason, Reason::kRejectAlreadyArmed);
  EXPECT_EQ(m.mode(), FlightMode::kManual);
}

TEST(Modes, ManualToAutoNeedsFreshVisionAndHealthyEstimator) {
  ModeMachine m = armed_in(FlightMode::kManual);
  ModeInputs in = ready();
  in.vision_time_us = in.now_us - 600000u;  // 0.6 s old: beyond FS_VIS_TIMEOUT 0.5 s
  EXPECT_EQ(m.command(Command::kAuto, in).reason, Reason::kRejectNoVision);
  in.vision_seen = false;
  EXPECT_EQ(m.command(Command::kAuto, in).reason, Reason::kRejectNoVision);
  in = ready();
  in.estimator_healthy = false;
  EXPECT_EQ(m.command(Command::kAuto, in).reason, Reason::kRejectEstimatorUnhealthy);
  EXPECT_EQ(m.mode(), FlightMode::kManual);
  in = ready();
  in.vision_time_us = in.now_us - 400000u;  // 0.4 s old: still fresh
  const auto t = m.command(Command::kAuto, in);
  EXPECT_TRUE(t.changed);
  EXPECT_EQ(t.reason, Reason::kAutoSelected);
  EXPECT_EQ(m.mode(), FlightMode::kAuto);
}

TEST(Modes, AutoRefusedWhenDisarmed) {
  ModeMachine m;
  EXPECT_EQ(m.command(Command::kAuto, ready()).reason, Reason::kRejectNotArmed);
  EXPECT_EQ(m.command(Command::kManual, ready()).reason, Reason::kRejectNotArmed);
  EXPECT_EQ(m.command(Command::kLand, ready()).reason, Reason::kRejectNotArmed);
  EXPECT_EQ(m.mode(), FlightMode::kDisarmed);
}

TEST(Modes, AutoBackToManualNeedsRc) {
  ModeMachine m = armed_in(FlightMode::kAuto);
  ModeInputs in = ready();
  in.rc_time_us = in.now_us - 2 * kSecond;
  EXPECT_EQ(m.command(Command::kManual, in).reason, Reason::kRejectNoRc);
  EXPECT_EQ(m.mode(), FlightMode::kAuto);
  const auto t = m.command(Command::kManual, ready());
  EXPECT_TRUE(t.changed);
  EXPECT_EQ(t.reason, Reason::kManualSelected);
  EXPECT_EQ(m.mode(), FlightMode::kManual);
}

TEST(Modes, LandCommandFromManualAndAuto) {
  for (FlightMode start : {FlightMode::kManual, FlightMode::kAuto}) {
    ModeMachine m = armed_in(start);
    const auto t = m.command(Command::kLand, ready());
    EXPECT_TRUE(t.changed);
    EXPECT_EQ(t.reason, Reason::kLandCommanded);
    EXPECT_EQ(m.mode(), FlightMode::kLanding);
    EXPECT_FALSE(m.land_level()) << "a fresh fix lets the landing hold its horizontal position";
  }
  ModeMachine m = armed_in(FlightMode::kManual);
  ModeInputs in = ready();
  in.vision_seen = false;
  m.command(Command::kLand, in);
  EXPECT_TRUE(m.land_level()) << "without a fix the landing must be level";
}

TEST(Modes, LandingCannotGoToAuto) {
  ModeMachine m = armed_in(FlightMode::kLanding);
  EXPECT_EQ(m.command(Command::kAuto, ready()).reason, Reason::kRejectLanding);
  EXPECT_EQ(m.mode(), FlightMode::kLanding);
}

TEST(Modes, LandingBackToManualWithFreshRc) {
  // The pilot takes over a landing (commanded, or a failsafe's once the sticks are back): MANUAL, and a
  // later landing starts afresh (not level when a fix is there).
  ModeMachine m = armed_in(FlightMode::kLanding);
  ModeInputs in = ready();
  in.landed = false;
  const auto t = m.command(Command::kManual, in);
  EXPECT_TRUE(t.accepted);
  EXPECT_TRUE(t.changed);
  EXPECT_EQ(t.from, FlightMode::kLanding);
  EXPECT_EQ(t.to, FlightMode::kManual);
  EXPECT_EQ(t.reason, Reason::kManualSelected);
  EXPECT_EQ(m.mode(), FlightMode::kManual);
  EXPECT_FALSE(m.land_level());

  // A level landing (the estimator failsafe) is left the same way and its level flag goes with it.
  m = armed_in(FlightMode::kAuto);
  in.estimator_healthy = false;
  ASSERT_EQ(m.update(in).reason, Reason::kFailsafeEstimator);
  ASSERT_TRUE(m.land_level());
  in.estimator_healthy = true;
  EXPECT_EQ(m.command(Command::kManual, in).reason, Reason::kManualSelected);
  EXPECT_EQ(m.mode(), FlightMode::kManual);
  EXPECT_FALSE(m.land_level()) << "level applies to a landing only";
  EXPECT_FALSE(m.update(in).changed) << "and MANUAL with fresh RC and a healthy estimator stays";
}

TEST(Modes, LandingBackToManualRefusedWithStaleRc) {
  ModeMachine m = armed_in(FlightMode::kLanding);
  ModeInputs in = ready();
  in.landed = false;
  in.rc_time_us = in.now_us - 1010000u;  // just beyond FS_RC_TIMEOUT 1 s
  const auto t = m.command(Command::kManual, in);
  EXPECT_FALSE(t.accepted);
  EXPECT_FALSE(t.changed);
  EXPECT_EQ(t.reason, Reason::kRejectNoRc);
  EXPECT_EQ(m.mode(), FlightMode::kLanding);
  EXPECT_FALSE(m.land_level()) << "the refusal leaves the landing as it was";
  in.rc_seen = false;  // never any RC
  EXPECT_EQ(m.command(Command::kManual, in).reason, Reason::kRejectNoRc);
  EXPECT_EQ(m.mode(), FlightMode::kLanding);
  // RC back, exactly at the timeout: fresh again, accepted.
  in.rc_seen = true;
  in.rc_time_us = in.now_us - 1000000u;
  EXPECT_EQ(m.command(Command::kManual, in).reason, Reason::kManualSelected);
  EXPECT_EQ(m.mode(), FlightMode::kManual);
}

TEST(Modes, LandingEndsDisarmedWhenLanded) {
  ModeMachine m = armed_in(FlightMode::kLanding);
  ModeInputs in = ready();
  in.landed = false;
  EXPECT_FALSE(m.update(in).changed);
  EXPECT_EQ(m.mode(), FlightMode::kLanding);
  in.landed = true;
  const auto t = m.update(in);
  EXPECT_TRUE(t.changed);
  EXPECT_EQ(t.reason, Reason::kLandedDisarmed);
  EXPECT_EQ(m.mode(), FlightMode::kDisarmed);
}

TEST(Modes, DisarmOnlyWhenLandedOrThrottleLowUnlessForced) {
  ModeMachine m = armed_in(FlightMode::kAuto);
  ModeInputs in = ready();
  in.landed = false;
  EXPECT_EQ(m.command(Command::kDisarm, in).reason, Reason::kRejectInFlight);
  EXPECT_TRUE(m.armed());
  in.landed = true;
  EXPECT_TRUE(m.command(Command::kDisarm, in).changed);
  EXPECT_FALSE(m.armed());

  // MANUAL with the throttle down counts as "on the ground" even before the land detector agrees.
  m = armed_in(FlightMode::kManual);
  in = ready();
  in.landed = false;
  EXPECT_TRUE(m.command(Command::kDisarm, in).changed);

  // Forced disarm (MAVLink param2 = 21196) is the kill switch.
  m = armed_in(FlightMode::kAuto);
  in.rc_throttle = 0.6f;
  const auto t = m.command(Command::kForceDisarm, in);
  EXPECT_TRUE(t.changed);
  EXPECT_EQ(t.reason, Reason::kDisarmed);
  EXPECT_EQ(m.mode(), FlightMode::kDisarmed);
}

TEST(Modes, FailsafeVisionLostInAutoLandsLevelAfterTimeout) {
  ModeMachine m = armed_in(FlightMode::kAuto);
  ModeInputs in = ready();
  in.landed = false;
  const uint32_t fix = in.now_us;
  in.now_us = fix + 500000u;  // exactly the timeout: still fresh
  EXPECT_FALSE(m.update(in).changed);
  EXPECT_EQ(m.mode(), FlightMode::kAuto);
  in.rc_time_us = in.now_us;
  in.now_us = fix + 510000u;
  in.rc_time_us = in.now_us;
  const auto t = m.update(in);
  EXPECT_TRUE(t.changed);
  EXPECT_EQ(t.reason, Reason::kFailsafeVisionLost);
  EXPECT_EQ(m.mode(), FlightMode::kLanding);
  EXPECT_TRUE(m.land_level());
}

TEST(Modes, VisionLossDoesNotMatterInManual) {
  ModeMachine m = armed_in(FlightMode::kManual);
  ModeInputs in = ready();
  in.landed = false;
  in.vision_seen = false;
  EXPECT_FALSE(m.update(in).changed);
  EXPECT_EQ(m.mode(), FlightMode::kManual);
}

TEST(Modes, FailsafeRcLostLandsAfterOneSecond) {
  for (FlightMode start : {FlightMode::kManual, FlightMode::kAuto}) {
    ModeMachine m = armed_in(start);
    ModeInputs in = ready();
    in.landed = false;
    const uint32_t rc = in.now_us;
    in.now_us = rc + 1000000u;
    in.vision_time_us = in.now_us;
    EXPECT_FALSE(m.update(in).changed);
    in.now_us = rc + 1010000u;
    in.vision_time_us = in.now_us;
    const auto t = m.update(in);
    EXPECT_TRUE(t.changed);
    EXPECT_EQ(t.reason, Reason::kFailsafeRcLost);
    EXPECT_EQ(m.mode(), FlightMode::kLanding);
    // In AUTO with a good fix the landing keeps holding position; from MANUAL it is level.
    EXPECT_EQ(m.land_level(), start == FlightMode::kManual);
  }
}

TEST(Modes, FailsafeEstimatorUnhealthyLandsLevel) {
  for (FlightMode start : {FlightMode::kManual, FlightMode::kAuto}) {
    ModeMachine m = armed_in(start);
    ModeInputs in = ready();
    in.landed = false;
    in.estimator_healthy = false;
    const auto t = m.update(in);
    EXPECT_TRUE(t.changed);
    EXPECT_EQ(t.reason, Reason::kFailsafeEstimator);
    EXPECT_EQ(m.mode(), FlightMode::kLanding);
    EXPECT_TRUE(m.land_level());
  }
}

TEST(Modes, LandingHoldingPositionTurnsLevelWhenVisionIsLostAndReportsIt) {
  ModeMachine m = armed_in(FlightMode::kLanding);
  ASSERT_FALSE(m.land_level());
  ModeInputs in = ready();
  in.landed = false;
  in.now_us += 600000u;
  in.rc_time_us = in.now_us;
  const auto t = m.update(in);
  EXPECT_FALSE(t.changed);
  EXPECT_EQ(t.reason, Reason::kFailsafeVisionLost);
  EXPECT_TRUE(m.land_level());
  // Reported once, and a fix coming back does not make the landing chase position again.
  in.vision_time_us = in.now_us;
  EXPECT_EQ(m.update(in).reason, Reason::kNone);
  EXPECT_TRUE(m.land_level());
}

TEST(Modes, ALandingBelowTheStarsViewLosesItWithoutAFailsafe) {
  // Below LAND_VIS_HGT the cameras see only a patch of the star: no failsafe, the landing keeps holding
  // its position on the estimate; above it the same loss is the failsafe (the test before).
  ModeMachine m = armed_in(FlightMode::kLanding);
  ModeInputs in = ready();
  in.landed = false;
  in.below_star_view = true;
  in.now_us += 3 * kSecond;
  in.rc_time_us = in.now_us;
  const auto t = m.update(in);
  EXPECT_FALSE(t.changed);
  EXPECT_EQ(t.reason, Reason::kNone);
  EXPECT_FALSE(m.land_level());
  // An unhealthy estimator is still the failsafe down there.
  in.estimator_healthy = false;
  EXPECT_EQ(m.update(in).reason, Reason::kFailsafeEstimator);
  EXPECT_TRUE(m.land_level());
}

TEST(Modes, AutoLosingTheStarLowIsStillTheFailsafe) {
  // Only a commanded landing expects the loss: hovering low in AUTO it is a failsafe.
  ModeMachine m = armed_in(FlightMode::kAuto);
  ModeInputs in = ready();
  in.landed = false;
  in.below_star_view = true;
  in.now_us += kSecond;
  in.rc_time_us = in.now_us;
  const auto t = m.update(in);
  EXPECT_TRUE(t.changed);
  EXPECT_EQ(t.reason, Reason::kFailsafeVisionLost);
  EXPECT_TRUE(m.land_level());
}

TEST(Modes, TimeoutsSurviveClockWrap) {
  ModeMachine m;
  ModeInputs in = ready(0xFFFFFF00u);
  ASSERT_TRUE(m.command(Command::kArm, in).changed);
  ASSERT_TRUE(m.command(Command::kAuto, in).changed);
  in.landed = false;
  in.now_us = 0xFFFFFF00u + 300000u;  // wrapped past zero, 0.3 s later
  in.rc_time_us = in.now_us;
  EXPECT_FALSE(m.update(in).changed);
  in.now_us = 0xFFFFFF00u + 700000u;
  in.rc_time_us = in.now_us;
  EXPECT_EQ(m.update(in).reason, Reason::kFailsafeVisionLost);
}

TEST(Modes, EveryReasonHasText) {
  for (int r = static_cast<int>(Reason::kArmed); r <= static_cast<int>(Reason::kRejectLanding); ++r) {
    const char* text = quad::fw::reason_text(static_cast<Reason>(r)).p;
    ASSERT_NE(text, nullptr);
    EXPECT_GT(strlen(text), 3u) << r;
    EXPECT_LE(strlen(text), 50u) << "STATUSTEXT holds 50 characters: " << text;
  }
}

}  // namespace

// The timeouts are compared in integer microseconds (ModeMachine keeps the largest fresh age): the
// result must be the float comparison of the specification, age <= 0 || float(age) <= timeout * 1e6,
// for every timeout (also beyond 2^24 us, where neighbouring integers share a float) and every age.
#include <cmath>
#include <limits>
#include <random>

TEST(Modes, FreshnessIsTheFloatComparisonOfTheTimeoutForEveryAge) {
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> timeouts = {0.5f, 1.0f, 0.05f, 10.0f, 0.1f, 0.3f, 1e-7f, 0.0f, -1.0f, 16.777216f, 16.777217f,
                                 17.0f, 33.5f, 100.0f, 1234.567f, 2147.48f, 2147.4836f, 2147.4837f, 3000.0f, inf,
                                 std::numeric_limits<float>::quiet_NaN()};
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> log_t(-6.0f, 3.5f);
  for (int i = 0; i < 300; ++i) timeouts.push_back(std::pow(10.0f, log_t(rng)));
  for (float timeout : timeouts) {
    quad::fw::ModeConfig c;
    c.vision_timeout_s = timeout;
    c.rc_timeout_s = timeout;
    const ModeMachine m(c);
    const float t = timeout * 1e6f;
    std::vector<int32_t> ages = {0, 1, -1, 2147483647, -2147483647 - 1};
    // Around the boundary: the integers near t (when it is in range), and random ones.
    if (t > -3e9f && t < 3e9f) {
      const int64_t center = static_cast<int64_t>(t);
      for (int64_t d = -200; d <= 200; ++d) {
        const int64_t a = center + d;
        if (a >= -2147483647 - 1 && a <= 2147483647) ages.push_back(static_cast<int32_t>(a));
      }
    }
    for (int i = 0; i < 2000; ++i) ages.push_back(static_cast<int32_t>(rng()));
    for (int32_t age : ages) {
      ModeInputs in = ready(0x80000000u);
      in.vision_time_us = in.now_us - static_cast<uint32_t>(age);
      in.rc_time_us = in.vision_time_us;
      const bool expected = age <= 0 || static_cast<float>(age) <= t;
      ASSERT_EQ(m.vision_fresh(in), expected) << "timeout " << timeout << " age " << age;
      ASSERT_EQ(m.rc_fresh(in), expected) << "timeout " << timeout << " age " << age;
    }
  }
}

TEST(Modes, DefaultMachineUsesTheDefaultConfigTimeouts) {
  const ModeMachine d;
  const ModeMachine c{quad::fw::ModeConfig()};
  for (int32_t age : {0, 499999, 500000, 500001, 999999, 1000000, 1000001}) {
    ModeInputs in = ready();
    in.vision_time_us = in.now_us - static_cast<uint32_t>(age);
    in.rc_time_us = in.vision_time_us;
    EXPECT_EQ(d.vision_fresh(in), c.vision_fresh(in)) << age;
    EXPECT_EQ(d.rc_fresh(in), c.rc_fresh(in)) << age;
    EXPECT_EQ(d.vision_fresh(in), age <= 500000) << age;
    EXPECT_EQ(d.rc_fresh(in), age <= 1000000) << age;
  }
}
