// Every transition of the mode table (docs/firmware.md "Modes and failsafes") driven through the flight
// application in MAVLink bytes, each asserting the exact STATUSTEXT that names the new mode (and its
// severity: failsafes are CRITICAL); and the numbers of the vision-lost failsafe's "hold level and
// descend at a safe rate" against a vehicle that really descends.
#include <gtest/gtest.h>

#include <cstdlib>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "app_bench.h"
#include "quad/firmware/app.h"

namespace {

using quad::fw::test::Bench;
using quad::fw::test::VerticalVehicle;
namespace mav = quad::mavlink;
using quad::fw::FlightMode;
constexpr float kG = quad::fw::test::kG;
using Texts = std::vector<std::string>;

void calibrate(Bench& b) {
  for (int i = 0; i < 250 && !b.app->calibrated(); ++i) b.still_step();
  ASSERT_TRUE(b.app->calibrated());
  // The pre-arm check: fixes of the vehicle at (0, 0, -1.5) m (hold()'s) initialise the position filter.
  for (int i = 0; i < 30 && b.app->estimator().preflight() != quad::fw::Preflight::kReady; ++i) {
    b.still_step();
    if (i % 3 == 0) b.landing_target(Eigen::Vector3f(0, 0, -1.5f), Eigen::Quaternionf::Identity(), b.t_us - 30000);
  }
  ASSERT_EQ(b.app->estimator().preflight(), quad::fw::Preflight::kReady);
}

// The STATUSTEXT lines sent since `mark` (an index into b.statustexts).
Texts since(const Bench& b, size_t mark) {
  Texts out;
  for (size_t i = mark; i < b.statustexts.size(); ++i) out.push_back(b.statustexts[i].second);
  return out;
}
uint8_t last_severity(const Bench& b) { return b.statustexts.empty() ? 255 : b.statustexts.back().first; }

// Still steps of a vehicle hovering at p (as far as the vision station can tell): a fix every third
// step (30 ms old), RC sticks every fifth, each optional.
void hold(Bench& b, int steps, bool fixes = true, bool rc = true, const Eigen::Vector3f& p = Eigen::Vector3f(0, 0, -1.5f)) {
  for (int i = 0; i < steps; ++i) {
    b.still_step();
    if (fixes && i % 3 == 0) b.landing_target(p, Eigen::Quaternionf::Identity(), b.t_us - 30000);
    if (rc && i % 5 == 0) b.sticks(0);
  }
}

// Calibrated and armed (MANUAL) with fresh fixes and RC.
void armed(Bench& b) {
  calibrate(b);
  b.sticks(0);
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  hold(b, 30);
  ASSERT_EQ(b.app->mode(), FlightMode::kManual);
}

void into_auto(Bench& b) {
  armed(b);
  ASSERT_EQ(b.set_mode(FlightMode::kAuto), mav::kResultAccepted);
  ASSERT_EQ(b.app->mode(), FlightMode::kAuto);
}

// Steps (with `fixes`, `rc`) until the mode is `mode`, at most max_steps; returns the steps taken.
int until(Bench& b, FlightMode mode, int max_steps, bool fixes, bool rc) {
  int n = 0;
  while (b.app->mode() != mode && n < max_steps) {
    hold(b, 1, fixes && n % 3 == 0, rc && n % 5 == 0);
    ++n;
  }
  return n;
}

TEST(ModeReports, EveryCommandedTransitionNamesTheNewMode) {
  Bench b;
  b.boot();
  calibrate(b);
  b.sticks(0);

  size_t mark = b.statustexts.size();
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  EXPECT_EQ(since(b, mark), Texts{"MANUAL: armed"});
  EXPECT_EQ(last_severity(b), mav::kSeverityInfo);
  EXPECT_EQ(b.app->mode(), FlightMode::kManual);

  mark = b.statustexts.size();
  hold(b, 30);
  EXPECT_EQ(since(b, mark), Texts{}) << "no transition, no text";

  // MANUAL -> AUTO
  mark = b.statustexts.size();
  ASSERT_EQ(b.set_mode(FlightMode::kAuto), mav::kResultAccepted);
  EXPECT_EQ(since(b, mark), Texts{"AUTO: auto selected"});
  EXPECT_EQ(last_severity(b), mav::kSeverityInfo);
  EXPECT_EQ(b.app->mode(), FlightMode::kAuto);
  hold(b, 20);

  // AUTO -> MANUAL
  mark = b.statustexts.size();
  ASSERT_EQ(b.set_mode(FlightMode::kManual), mav::kResultAccepted);
  EXPECT_EQ(since(b, mark), Texts{"MANUAL: manual selected"});
  EXPECT_EQ(b.app->mode(), FlightMode::kManual);
  hold(b, 20);

  // AUTO -> LANDING by MAV_CMD_NAV_LAND
  ASSERT_EQ(b.set_mode(FlightMode::kAuto), mav::kResultAccepted);
  hold(b, 20);
  mark = b.statustexts.size();
  ASSERT_EQ(b.command(mav::kCmdNavLand), mav::kResultAccepted);
  EXPECT_EQ(since(b, mark), Texts{"LANDING: land commanded"});
  EXPECT_EQ(last_severity(b), mav::kSeverityInfo);
  EXPECT_EQ(b.app->mode(), FlightMode::kLanding);

  // LANDING -> MANUAL: the pilot takes over (RC fresh).
  mark = b.statustexts.size();
  ASSERT_EQ(b.set_mode(FlightMode::kManual), mav::kResultAccepted);
  EXPECT_EQ(since(b, mark), Texts{"MANUAL: manual selected"});
  EXPECT_EQ(b.app->mode(), FlightMode::kManual);
  hold(b, 20);

  // MANUAL -> LANDING by DO_SET_MODE custom mode 3, then LANDING -> DISARMED by the land detector (on
  // the ground with the throttle down it needs LAND_TIME, 1 s).
  mark = b.statustexts.size();
  ASSERT_EQ(b.set_mode(FlightMode::kLanding), mav::kResultAccepted);
  EXPECT_EQ(since(b, mark), Texts{"LANDING: land commanded"});
  EXPECT_EQ(b.app->mode(), FlightMode::kLanding);
  mark = b.statustexts.size();
  const int steps = until(b, FlightMode::kDisarmed, 300, true, true);
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);
  EXPECT_GE(steps, 99) << "LAND_TIME of quiet first";
  EXPECT_LE(steps, 102);
  EXPECT_EQ(since(b, mark), Texts{"DISARMED: landed, disarmed"});
  EXPECT_EQ(last_severity(b), mav::kSeverityInfo);

  // Arm again, and the disarm command (on the ground, throttle down).
  b.sticks(0);
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  hold(b, 10);
  mark = b.statustexts.size();
  ASSERT_EQ(b.command(mav::kCmdComponentArmDisarm, 0.0f), mav::kResultAccepted);
  EXPECT_EQ(since(b, mark), Texts{"DISARMED: disarmed"});
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);
  // The kill switch: forced disarm (param2 21196) from AUTO in the air.
  b.sticks(0);
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  hold(b, 10);
  ASSERT_EQ(b.set_mode(FlightMode::kAuto), mav::kResultAccepted);
  hold(b, 20);
  mark = b.statustexts.size();
  ASSERT_EQ(b.command(mav::kCmdComponentArmDisarm, 0.0f, 21196.0f), mav::kResultAccepted);
  EXPECT_EQ(since(b, mark), Texts{"DISARMED: disarmed"});
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);
}

TEST(ModeReports, RefusalsNameNoNewModeAndKeepIt) {
  Bench b;
  b.boot();
  ASSERT_EQ(b.app->override_param(quad::fw::kFsRcEnable, 0.0f), nullptr);  // no RC failsafe
  calibrate(b);
  ASSERT_EQ(b.arm(), mav::kResultAccepted) << "RC not required";
  hold(b, 30, true, false);
  ASSERT_EQ(b.set_mode(FlightMode::kAuto), mav::kResultAccepted);
  hold(b, 20, true, false);
  // AUTO -> MANUAL needs fresh RC even when RC is not required (no sticks to fly by).
  size_t mark = b.statustexts.size();
  EXPECT_EQ(b.set_mode(FlightMode::kManual), mav::kResultDenied);
  EXPECT_EQ(since(b, mark), Texts{"refused: no RC"});
  EXPECT_EQ(last_severity(b), mav::kSeverityWarning);
  EXPECT_EQ(b.app->mode(), FlightMode::kAuto);
  // LANDING -> AUTO is refused.
  ASSERT_EQ(b.command(mav::kCmdNavLand), mav::kResultAccepted);
  mark = b.statustexts.size();
  EXPECT_EQ(b.set_mode(FlightMode::kAuto), mav::kResultDenied);
  EXPECT_EQ(since(b, mark), Texts{"refused: landing"});
  EXPECT_EQ(b.app->mode(), FlightMode::kLanding);
  // LANDING -> MANUAL without RC: refused, still landing.
  mark = b.statustexts.size();
  EXPECT_EQ(b.set_mode(FlightMode::kManual), mav::kResultDenied);
  EXPECT_EQ(since(b, mark), Texts{"refused: no RC"});
  EXPECT_EQ(b.app->mode(), FlightMode::kLanding);
}

TEST(ModeReports, AJumpOfTheEstimateToTheFixIsReported) {
  // A persistent jump of the fix (a decoy taken for the star, a moved marker): the filter's gate refuses
  // it until the estimate's growing uncertainty lets it in. The mode stays, but the operator is told,
  // once per jump. (A jump so large that the refusals outlast FS_VIS_TIMEOUT is the vision-lost
  // failsafe instead: refused fixes are no vision.)
  for (const float jump : {2.0f, 3.0f}) {
    Bench b;
    b.boot();
    into_auto(b);
    hold(b, 60);
    size_t mark = b.statustexts.size();
    hold(b, 30);
    EXPECT_TRUE(since(b, mark).empty()) << "steady fixes: nothing to report";
    hold(b, 3 * 25, true, true, Eigen::Vector3f(jump, 0.0f, -1.5f));  // 25 fixes `jump` m north
    const Texts said = since(b, mark);
    ASSERT_EQ(said.size(), 1u) << jump << " m";
    const std::string prefix = "position jumped to the fix after ";
    ASSERT_EQ(said.front().rfind(prefix, 0), 0u) << said.front();
    const int refused = std::atoi(said.front().c_str() + prefix.size());
    EXPECT_EQ(said.front(), prefix + std::to_string(refused) + " rejected");
    EXPECT_GE(refused, 3) << jump << " m";
    EXPECT_EQ(b.statustexts[mark].first, mav::kSeverityWarning);
    EXPECT_NEAR(b.app->position().x, jump, 0.1f);
    EXPECT_EQ(b.app->mode(), FlightMode::kAuto) << "a jump is not a failsafe";
    mark = b.statustexts.size();
    hold(b, 60, true, true, Eigen::Vector3f(jump, 0.0f, -1.5f));
    EXPECT_TRUE(since(b, mark).empty()) << "fused again: no more reports";
  }
}

// After `mark`, the first STATUSTEXT is `text` at CRITICAL severity, and the mode went to LANDING
// within [min_steps, max_steps] of the cause (steps as `until` counted them).
void expect_failsafe_report(const Bench& b, size_t mark, int steps, int min_steps, int max_steps, const std::string& text) {
  EXPECT_EQ(b.app->mode(), FlightMode::kLanding);
  EXPECT_GE(steps, min_steps);
  EXPECT_LE(steps, max_steps);
  ASSERT_FALSE(since(b, mark).empty());
  EXPECT_EQ(since(b, mark).front(), text);
  EXPECT_EQ(b.statustexts[mark].first, mav::kSeverityCritical);
}

TEST(ModeReports, VisionLostFailsafeInAuto) {
  Bench b;
  b.boot();
  into_auto(b);
  hold(b, 20);
  const size_t mark = b.statustexts.size();
  // Fixes stop, RC goes on: LANDING 0.5 s (FS_VIS_TIMEOUT) after the last fix arrived.
  const int steps = until(b, FlightMode::kLanding, 200, false, true);
  expect_failsafe_report(b, mark, steps, 49, 52, "LANDING: FAILSAFE vision lost: level, land");
}

TEST(ModeReports, RcLostFailsafeFromManualAndFromAuto) {
  for (FlightMode start : {FlightMode::kManual, FlightMode::kAuto}) {
    SCOPED_TRACE(start == FlightMode::kManual ? "from MANUAL" : "from AUTO");
    Bench b;
    b.boot();
    if (start == FlightMode::kManual) armed(b);
    else into_auto(b);
    hold(b, 10);
    const size_t mark = b.statustexts.size();
    // The sticks stop (the fixes go on): LANDING 1 s (FS_RC_TIMEOUT) after the last RC frame.
    const int steps = until(b, FlightMode::kLanding, 200, true, false);
    expect_failsafe_report(b, mark, steps, 96, 101, "LANDING: FAILSAFE RC lost: land");
    // On the ground the landing ends, reported as such.
    until(b, FlightMode::kDisarmed, 300, true, false);
    EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);
    EXPECT_EQ(since(b, mark), (Texts{"LANDING: FAILSAFE RC lost: land", "DISARMED: landed, disarmed"}));
  }
}

// A shock: every IMU axis at full scale for one step (imu_clip.h); longer than IMU_CLIP_HOLD (50 ms)
// the estimator is unhealthy.
void clipped_step(Bench& b) {
  const float gyro_range = b.app->params().get(quad::fw::kImuGyroRange);
  const float accel_range = b.app->params().get(quad::fw::kImuAccRange);
  const Eigen::Vector3f g = Eigen::Vector3f::Constant(gyro_range) - b.gyro_bias;
  const Eigen::Vector3f a = Eigen::Vector3f(accel_range, -accel_range, -accel_range) - b.accel_bias;
  b.hil_step(Eigen::Quaternionf::Identity(), a, g);
}

TEST(ModeReports, EstimatorFailsafeFromManualAndFromAuto) {
  for (FlightMode start : {FlightMode::kManual, FlightMode::kAuto}) {
    SCOPED_TRACE(start == FlightMode::kManual ? "from MANUAL" : "from AUTO");
    Bench b;
    b.boot();
    if (start == FlightMode::kManual) armed(b);
    else into_auto(b);
    hold(b, 10);
    const size_t mark = b.statustexts.size();
    int clipped = 0;
    while (b.app->mode() == start && clipped < 20) {
      clipped_step(b);
      ++clipped;
      if (clipped % 5 == 0) b.sticks(0);
    }
    EXPECT_EQ(clipped, 6) << "the sixth clipped sample (60 ms) is beyond the 50 ms hold";
    EXPECT_NE(b.app->mode(), start);
    const Texts said = since(b, mark);
    const auto it = std::find(said.begin(), said.end(), "LANDING: FAILSAFE estimator unhealthy: land");
    ASSERT_NE(it, said.end()) << ::testing::PrintToString(said);
    EXPECT_EQ(b.statustexts[mark + static_cast<size_t>(it - said.begin())].first, mav::kSeverityCritical);
    // Nothing else changed the mode before it (the clip burst has its own, mode-less line).
    for (auto t = said.begin(); t != it; ++t) EXPECT_EQ(t->rfind("IMU clipping:", 0), 0u) << *t;
  }
}

TEST(ModeReports, LandingHoldingPositionLosesTheFixAndTurnsLevel) {
  Bench b;
  b.boot();
  into_auto(b);
  hold(b, 20);
  size_t mark = b.statustexts.size();
  ASSERT_EQ(b.command(mav::kCmdNavLand), mav::kResultAccepted);
  EXPECT_EQ(since(b, mark), Texts{"LANDING: land commanded"});
  // The fixes stop at once: 0.5 s later the landing turns level, reported without a mode change (the
  // vehicle is still, so the land detector needs its 1 s and comes second).
  mark = b.statustexts.size();
  until(b, FlightMode::kDisarmed, 300, false, true);
  EXPECT_EQ(since(b, mark), (Texts{"FAILSAFE vision lost: level, land", "DISARMED: landed, disarmed"}));
  ASSERT_EQ(b.statustexts.size(), mark + 2);
  EXPECT_EQ(b.statustexts[mark].first, mav::kSeverityCritical);
}

// --- The vision-lost failsafe in numbers -----------------------------------------------------------


// Torque shares of the last motor commands, plus layout (VEH_FRAME 0; motor 0 front, 1 left, 2 back,
// 3 right): pitch (nose up) ~ f_front - f_back, roll (right down) ~ f_left - f_right, as a fraction of
// the mean rotor thrust. A level attitude command on a level vehicle asks for neither.
struct Differential {
  float pitch = 0.0f, roll = 0.0f;
};
Differential differential(const Bench& b) {
  const float* u = b.actuators.back().controls;
  float f[4], mean = 0.0f;
  for (int i = 0; i < 4; ++i) mean += (f[i] = u[i] * u[i]) / 4.0f;
  if (!(mean > 0.0f)) return Differential{};
  return Differential{(f[0] - f[2]) / mean, (f[1] - f[3]) / mean};
}

// A flight of the VerticalVehicle in the Bench: take-off in AUTO to `height` (fixes from the true
// height at 33 Hz, 10 ms old, RC at 20 Hz).
class Flight {
 public:
  explicit Flight(float land_speed) {
    b.gyro_bias.setZero();
    b.boot();
    EXPECT_EQ(b.app->override_param(quad::fw::kLandSpeed, land_speed), nullptr);
    calibrate(b);
    b.sticks(0);
    EXPECT_EQ(b.arm(), mav::kResultAccepted);
    fly(30, true);
    EXPECT_EQ(b.set_mode(FlightMode::kAuto), mav::kResultAccepted);
  }
  void climb_to(float z) {
    b.position_target(z);
    fly(1000, true);
    EXPECT_NEAR(v.z, z, 0.05f);
  }
  // One step; with a fix (every third step) at the true height and horizontal position fix_ne.
  void step(bool fixes) {
    b.hil_step(Eigen::Quaternionf::Identity(), Eigen::Vector3f(0, 0, f_z_));
    f_z_ = v.step(b.actuators.back().controls, 0.01f);
    if (fixes && i_ % 3 == 0) {
      b.landing_target(Eigen::Vector3f(fix_ne.x(), fix_ne.y(), v.z), Eigen::Quaternionf::Identity(), b.t_us - 10000);
    }
    if (i_ % 5 == 0) b.sticks(0);
    ++i_;
  }
  void fly(int steps, bool fixes) {
    for (int k = 0; k < steps; ++k) step(fixes);
  }

  Bench b;
  VerticalVehicle v;
  Eigen::Vector2f fix_ne = Eigen::Vector2f::Zero();

 private:
  float f_z_ = -kG;
  int i_ = 0;
};

TEST(VisionLostFailsafe, HoldsLevelAndDescendsAtLandSpeed) {
  constexpr float kLandSpeed = 0.35f;  // not the default 0.5 m/s: the parameter is what counts
  Flight fl(kLandSpeed);
  Bench& b = fl.b;
  fl.climb_to(-3.0f);
  ASSERT_EQ(b.app->mode(), FlightMode::kAuto);
  // 10 s of hover first: the filter's vertical bias state (KF_Z_BIAS) takes part of the climb's
  // acceleration for bias (this bench's accelerometer is a step late) and gives it back over seconds; a
  // vision loss right at the top would dead-reckon with it (docs/estimation.md, "From the touchdown").
  const float climb_bias = b.app->estimator().filter_accel_bias().z;
  fl.fly(1000, true);
  std::printf("[figure] vertical bias state after the 3 m climb %.4f m/s^2, after 10 s of hover %.4f m/s^2\n",
              climb_bias, b.app->estimator().filter_accel_bias().z);

  // The fixes stop: LANDING, level, 0.5 s later.
  const size_t mark = b.statustexts.size();
  int steps = 0;
  while (b.app->mode() == FlightMode::kAuto && steps < 200) {
    fl.step(false);
    ++steps;
  }
  ASSERT_EQ(b.app->mode(), FlightMode::kLanding);
  EXPECT_EQ(since(b, mark), Texts{"LANDING: FAILSAFE vision lost: level, land"});
  EXPECT_LE(steps, 52);

  // 1 s to settle on the descent rate, then 1 s measured: the vehicle sinks at LAND_SPEED, and the
  // motors ask for no roll or pitch.
  float worst_pitch = 0.0f, worst_roll = 0.0f;
  float vz_min = 1e9f, vz_max = -1e9f;
  auto track = [&] {
    const Differential d = differential(b);
    worst_pitch = std::max(worst_pitch, std::fabs(d.pitch));
    worst_roll = std::max(worst_roll, std::fabs(d.roll));
    vz_min = std::min(vz_min, fl.v.vz);
    vz_max = std::max(vz_max, fl.v.vz);
  };
  for (int k = 0; k < 100; ++k) fl.step(false);
  EXPECT_NEAR(fl.v.vz, kLandSpeed, 0.02f) << "settled within 1 s";
  const float z0 = fl.v.z;
  for (int k = 0; k < 100; ++k) {
    fl.step(false);
    track();
  }
  const float rate = fl.v.z - z0;  // over 1 s
  EXPECT_NEAR(rate, kLandSpeed, 0.01f) << "mean descent rate (NED, down +)";
  EXPECT_NEAR(vz_min, kLandSpeed, 0.02f);
  EXPECT_NEAR(vz_max, kLandSpeed, 0.02f);
  EXPECT_NEAR(b.app->velocity().z, kLandSpeed, 0.02f) << "the estimate agrees, without fixes";
  EXPECT_LT(worst_pitch, 1e-3f);
  EXPECT_LT(worst_roll, 1e-3f);

  // Fixes come back (2.5 s into the outage), 0.4 m north of where the landing began: they are fused
  // (the estimate moves), but the level landing does not chase them (a landing holding position pitches
  // by tens of percent of the thrust here: CommandedLandingWithAFixDoesHoldPosition), and the descent
  // goes on at LAND_SPEED.
  fl.fix_ne = Eigen::Vector2f(0.4f, 0.0f);
  for (int k = 0; k < 150; ++k) {
    fl.step(true);
    track();
  }
  EXPECT_GT(b.app->position().x, 0.3f) << "the displaced fixes were fused";
  EXPECT_EQ(b.app->mode(), FlightMode::kLanding);
  EXPECT_LT(worst_pitch, 1e-3f);
  EXPECT_LT(worst_roll, 1e-3f);
  EXPECT_NEAR(vz_min, kLandSpeed, 0.02f);
  EXPECT_NEAR(vz_max, kLandSpeed, 0.02f);
  std::printf("vision-lost landing: descent %.4f m/s (LAND_SPEED %.2f), vz %.4f..%.4f, worst pitch/roll share %.2g / %.2g\n",
              rate, kLandSpeed, vz_min, vz_max, worst_pitch, worst_roll);

  // Down and disarmed.
  for (int k = 0; k < 1200 && b.app->mode() != FlightMode::kDisarmed; ++k) fl.step(true);
  EXPECT_NEAR(fl.v.z, 0.0f, 1e-3f);
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);
  EXPECT_EQ(b.statustexts.back().second, "DISARMED: landed, disarmed");
}

TEST(VisionLostFailsafe, CommandedLandingWithAFixDoesHoldPosition) {
  // The control of the test above: the same displaced fixes in a landing that holds its position (land
  // commanded with a fresh fix) do tilt the vehicle back towards where the landing began (nose up,
  // braking south: the front motor pulls harder), so `differential` sees a tilt command.
  constexpr float kLandSpeed = 0.35f;
  Flight fl(kLandSpeed);
  Bench& b = fl.b;
  fl.climb_to(-3.0f);
  ASSERT_EQ(b.command(mav::kCmdNavLand), mav::kResultAccepted);
  ASSERT_EQ(b.app->mode(), FlightMode::kLanding);
  fl.fly(100, true);
  EXPECT_LT(std::fabs(differential(b).pitch), 1e-3f) << "before the displaced fixes: level";
  fl.fix_ne = Eigen::Vector2f(0.4f, 0.0f);
  float max_pitch = 0.0f;
  for (int k = 0; k < 150; ++k) {
    fl.step(true);
    max_pitch = std::max(max_pitch, differential(b).pitch);
  }
  EXPECT_GT(b.app->position().x, 0.3f);
  EXPECT_GT(max_pitch, 0.02f);
  EXPECT_LT(std::fabs(differential(b).roll), 1e-3f);
  std::printf("landing holding position, fix 0.4 m off: pitch share up to %.3f\n", max_pitch);
}

}  // namespace
