// The flight application in-process, spoken to only in MAVLink bytes as the simulator, the ground
// station and the vision station would: boot calibration, arming checks, the vision path (eq. 8.5 with
// the errata sign, attitude at the capture time), the parameter protocol and store, failsafes, and a
// whole vertical flight (take-off in AUTO, land, disarm) against a point-mass vehicle.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <iostream>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "float_cases.h"
#include "app_bench.h"
#include "quad/firmware/app.h"

namespace {

using quad_test::bits_of;

using quad::fw::test::Bench;
using quad::fw::test::VerticalVehicle;
using quad::fw::test::VerticalFlight;
namespace mav = quad::mavlink;
using quad::fw::FlightMode;
constexpr float kG = quad::fw::test::kG;

void calibrate(Bench& b, const Eigen::Quaternionf& q = Eigen::Quaternionf::Identity()) {
  for (int i = 0; i < 1000 && !b.app->calibrated(); ++i) b.still_step(q);
  ASSERT_TRUE(b.app->calibrated());
}

TEST(FirmwareApp, BootReportsEmptyStoreAndCalibration) {
  Bench b;
  b.boot();
  EXPECT_EQ(b.app->store_status(), quad::fw::StoreStatus::kEmpty);
  EXPECT_TRUE(b.said("params: store empty, defaults"));
  EXPECT_TRUE(b.said("calibrating"));
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);
}

TEST(FirmwareApp, CalibrationRemovesBothBiasesAndFindsTheHeading) {
  // Level, heading 40 deg, gyro and accelerometer biased: after calibration (thesis eq. 7.2, 7.4) the
  // estimate must neither tilt nor drift over the following seconds.
  Bench b;
  b.boot();
  const Eigen::Quaternionf q(Eigen::AngleAxisf(0.698f, Eigen::Vector3f::UnitZ()));
  calibrate(b, q);
  EXPECT_TRUE(b.said("calibrated, ready to arm"));
  for (int i = 0; i < 500; ++i) b.still_step(q);
  const quad::Quat est = b.app->attitude();
  const float err = Eigen::Quaternionf(est.w, est.x, est.y, est.z).angularDistance(q);
  EXPECT_LT(err, 0.01f) << "attitude error " << err << " rad";
  // The accelerometer bias is gone: a still vehicle's position estimate stays put (no 0.2 m/s^2 ramp,
  // which would give 2.5 m in 5 s).
  EXPECT_LT(quad::norm(b.app->velocity()), 0.05f);
}

// The simulator's magnetometer (docs/simulator.md): soft iron of thesis eq. 7.6 with scale errors
// (1.03, 0.97, 1.01) and misalignments (0.02, -0.015, 0.01) rad, hard iron (0.04, -0.03, 0.06) G, and a
// field of (0.20, -0.02, 0.45) G NED: declination atan2(-0.02, 0.20) = -5.7 deg.
struct SimMagnetometer {
  Eigen::Matrix3f d;
  Eigen::Vector3f b{0.04f, -0.03f, 0.06f};
  Eigen::Vector3f field{0.20f, -0.02f, 0.45f};
  SimMagnetometer() {
    const Eigen::Vector3f e(1.03f, 0.97f, 1.01f), m(0.02f, -0.015f, 0.01f);
    d << e[0], 0, 0, e[1] * std::sin(m[0]), e[1] * std::cos(m[0]), 0, e[2] * std::sin(m[1]) * std::cos(m[2]),
        e[2] * std::sin(m[2]), e[2] * std::cos(m[1]) * std::cos(m[2]);
  }
};

// Heading error (rad) of a vehicle calibrated and held still at `yaw`.
float heading_error(Bench& b, float yaw) {
  const Eigen::Quaternionf q(Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitZ()));
  calibrate(b, q);
  for (int i = 0; i < 300; ++i) b.still_step(q);
  const quad::Quat est = b.app->attitude();
  return Eigen::Quaternionf(est.w, est.x, est.y, est.z).angularDistance(q);
}

TEST(FirmwareApp, MagnetometerCalibrationAndDeclinationGiveTheTrueHeading) {
  const SimMagnetometer sim;
  const Eigen::Matrix3f w = sim.d.inverse();
  for (float yaw : {0.698f, -2.1f}) {
    Bench raw;
    raw.mag_ned = sim.field;
    raw.mag_distortion = sim.d;
    raw.mag_hard_iron = sim.b;
    raw.boot();
    const float err_raw = heading_error(raw, yaw);
    EXPECT_GT(err_raw, 2.0f * 3.14159f / 180.0f) << "without calibration the heading is off (2-13 deg here)";

    Bench cal;
    cal.mag_ned = sim.field;
    cal.mag_distortion = sim.d;
    cal.mag_hard_iron = sim.b;
    cal.boot();
    const uint8_t ofs[3] = {quad::fw::kMagOfsX, quad::fw::kMagOfsY, quad::fw::kMagOfsZ};
    for (int i = 0; i < 3; ++i) ASSERT_EQ(cal.app->override_param(ofs[i], sim.b[i]), nullptr);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        ASSERT_EQ(cal.app->override_param(static_cast<uint8_t>(quad::fw::kMagSiXX + 3 * r + c), w(r, c)), nullptr);
      }
    }
    ASSERT_EQ(cal.app->override_param(quad::fw::kMagDecl, std::atan2(sim.field.y(), sim.field.x())), nullptr);
    const float err_cal = heading_error(cal, yaw);
    EXPECT_LT(err_cal, 0.5f * 3.14159f / 180.0f) << "yaw " << yaw;
    std::printf("heading error at yaw %.2f rad: %.2f deg raw, %.3f deg calibrated\n", yaw, err_raw * 57.2958f,
                err_cal * 57.2958f);
  }
}

TEST(FirmwareApp, DeclinationAloneTurnsTheHeadingAndASingularSoftIronMatrixIsRefused) {
  Bench b;
  b.mag_ned = Eigen::Vector3f(0.2f * std::cos(0.3f), 0.2f * std::sin(0.3f), 0.45f);  // 0.3 rad east
  b.boot();
  ASSERT_EQ(b.app->override_param(quad::fw::kMagDecl, 0.3f), nullptr);
  EXPECT_LT(heading_error(b, 1.0f), 0.005f);
  // Changed in flight: the reference turns with it, and the heading follows.
  ASSERT_EQ(b.app->override_param(quad::fw::kMagDecl, 0.0f), nullptr);
  const Eigen::Quaternionf q(Eigen::AngleAxisf(1.0f, Eigen::Vector3f::UnitZ()));
  for (int i = 0; i < 6000; ++i) b.still_step(q);
  EXPECT_NEAR(quad::to_euler(b.app->attitude()).yaw, 0.7f, 0.02f) << "the magnetic heading now (true - 0.3 rad)";
  EXPECT_NE(b.app->override_param(quad::fw::kMagSiYY, 0.0f), nullptr);
  EXPECT_STREQ(b.app->override_param(quad::fw::kMagSiYY, 0.0f), "MAG_SI (singular)");
}

TEST(FirmwareApp, CalibrationWaitsForALevelVehicle) {
  Bench b;
  b.boot();
  const Eigen::Quaternionf tilted(Eigen::AngleAxisf(0.2f, Eigen::Vector3f::UnitX()));  // 11 deg
  for (int i = 0; i < 450; ++i) b.still_step(tilted);
  EXPECT_FALSE(b.app->calibrated());
  EXPECT_TRUE(b.said("calibration: not level, again"));
  // Set down level: the window under way mixes both attitudes and is refused, the next one passes.
  for (int i = 0; i < 400; ++i) b.still_step();
  EXPECT_TRUE(b.app->calibrated());
}

TEST(FirmwareApp, CalibrationRestartsWhenTheVehicleMoves) {
  Bench b;
  b.boot();
  for (int i = 0; i < 150; ++i) b.still_step();  // 1.5 s of the 2 s window
  // A bump: 0.5 rad/s for one sample.
  b.hil_step(Eigen::Quaternionf::Identity(), Eigen::Vector3f(0, 0, -kG), Eigen::Vector3f(0.5f, 0, 0));
  for (int i = 0; i < 100; ++i) b.still_step();
  EXPECT_FALSE(b.app->calibrated()) << "the window with the bump is thrown away";
  EXPECT_TRUE(b.said("calibration: vehicle moved, again"));
  for (int i = 0; i < 200; ++i) b.still_step();
  EXPECT_TRUE(b.app->calibrated()) << "the next still window counts";
}

TEST(FirmwareApp, ArmingChecksOverMavlink) {
  Bench b;
  b.boot();
  b.sticks(0);
  EXPECT_EQ(b.arm(), mav::kResultDenied) << "not calibrated yet";
  EXPECT_TRUE(b.said("PREFLIGHT: estimator not converged: calibrating"));
  calibrate(b);
  quad::fw::test::ready_to_arm(b);
  b.sticks(600);
  EXPECT_EQ(b.arm(), mav::kResultDenied);
  EXPECT_TRUE(b.said("arm refused: throttle not low"));
  b.sticks(0);
  EXPECT_EQ(b.arm(), mav::kResultAccepted);
  EXPECT_TRUE(b.said("MANUAL: armed"));
  b.still_step();
  ASSERT_FALSE(b.actuators.empty());
  EXPECT_NE(b.actuators.back().mode & mav::kModeFlagSafetyArmed, 0);
  EXPECT_EQ(b.command(999), mav::kResultUnsupported);
  EXPECT_EQ(b.command(mav::kCmdDoSetMode, 1.0f, 7.0f), mav::kResultDenied) << "no custom mode 7";
}

TEST(FirmwareApp, FlagsItsAnswersWithTheModeTheSimulatorAskedFor) {
  Bench b;
  b.boot();
  for (int i = 0; i < 3; ++i) b.still_step();
  ASSERT_FALSE(b.actuators.empty());
  EXPECT_EQ(b.actuators.back().flags, mav::kHilActuatorControlsFlagLockstep) << "HIL_LOCKSTEP 1 by default";
  ASSERT_EQ(b.app->override_param(quad::fw::kHilLockstep, 0.0f), nullptr);  // quad_sim --realtime
  const size_t before = b.actuators.size();
  for (int i = 0; i < 3; ++i) b.still_step();
  ASSERT_EQ(b.actuators.size(), before + 3) << "still one answer per HIL_SENSOR";
  EXPECT_EQ(b.actuators.back().flags, 0u);
}

TEST(FirmwareApp, AnswersEachHilSensorOnceAndRepeatsWithoutSteppingTwice) {
  Bench b;
  b.boot();
  for (int i = 0; i < 10; ++i) b.still_step();
  ASSERT_EQ(b.actuators.size(), 10u);
  const uint32_t iterations = b.app->counters().iterations;
  // The simulator missed an answer and repeats the last step.
  b.t_us -= 10000;
  b.still_step();
  EXPECT_EQ(b.actuators.size(), 11u);
  EXPECT_EQ(b.actuators[10].time_usec, b.actuators[9].time_usec);
  EXPECT_EQ(b.app->counters().iterations, iterations);
}

TEST(FirmwareApp, BoardModeIntegratesOverTheStepPeriodNotTheLastReceive) {
  // On a board the runner calls step() at SYS_LOOP_HZ and receive() whenever bytes arrive; a turn of
  // 1 rad/s for 1 s must come out as 1 rad whatever arrives in between.
  Bench b;
  b.gyro_bias.setZero();
  b.boot(/*hil=*/false);
  auto board_step = [&](const Eigen::Quaternionf& q, float yaw_rate) {
    quad::hal::ImuSample imu;
    const Eigen::Vector3f f = q.conjugate() * Eigen::Vector3f(0, 0, -kG);
    imu.accel = quad::Vec3{f.x(), f.y(), f.z()};
    imu.gyro = quad::Vec3{0.0f, 0.0f, yaw_rate};
    quad::hal::MagSample mag;
    const Eigen::Vector3f m = q.conjugate() * Eigen::Vector3f(0.21f, 0.0f, 0.43f);
    mag.field = quad::Vec3{m.x(), m.y(), m.z()};
    b.app->step(static_cast<uint32_t>(b.t_us), imu, &mag);
    b.t_us += 3000;
    b.sticks(0);  // bytes arriving 3 ms after the step
    b.t_us += 7000;
  };
  for (int i = 0; i < 250 && !b.app->calibrated(); ++i) board_step(Eigen::Quaternionf::Identity(), 0.0f);
  ASSERT_TRUE(b.app->calibrated());
  float yaw = 0.0f;
  for (int i = 0; i < 100; ++i) {
    board_step(Eigen::Quaternionf(Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitZ())), 1.0f);
    yaw += 0.01f;
  }
  const quad::Quat q = b.app->attitude();
  // The magnetometer pulls towards the truth too, so compare with the true heading after the turn.
  EXPECT_NEAR(quad::to_euler(q).yaw, 0.99f, 0.03f);
  EXPECT_TRUE(b.actuators.empty()) << "no HIL_ACTUATOR_CONTROLS on a board";
}

TEST(FirmwareApp, LandingTargetGivesTheVehiclePositionWithTheErrataSign) {
  // Vehicle at (1.0, -0.5, -1.5) NED, yawed 60 deg, star at VIS_STAR (2, 1, 0): thesis eq. 8.5 with the
  // errata, p = s - R p_B. A sign error would put the estimate on the other side of the star.
  Bench b;
  b.boot();
  const Eigen::Quaternionf q(Eigen::AngleAxisf(1.047f, Eigen::Vector3f::UnitZ()));
  const Eigen::Vector3f p(1.0f, -0.5f, -1.5f), star(2.0f, 1.0f, 0.0f);
  b.set_param("VIS_STAR_N", 2.0f);
  b.set_param("VIS_STAR_E", 1.0f);
  calibrate(b, q);
  // Hovering (still) at p: fixes at 30 Hz captured 60 ms before they arrive.
  // (The first fixes wait until the attitude history reaches back to their capture time.)
  for (int i = 0; i < 200; ++i) {
    b.still_step(q);
    if (i >= 10 && i % 3 == 0) b.landing_target(p, q, b.t_us - 60000, star);
  }
  const quad::Vec3 est = b.app->position();
  EXPECT_NEAR(est.x, p.x(), 0.02f);
  EXPECT_NEAR(est.y, p.y(), 0.02f);
  EXPECT_NEAR(est.z, p.z(), 0.02f);
  EXPECT_GT(b.app->counters().fixes_fused, 60u);
  // (The printed sign, p = R p_B, would have put it at s - p = (1, 1.5, 1.5).)
  EXPECT_EQ(b.app->counters().fixes_rejected, 0u);
}

TEST(FirmwareApp, LandingTargetUsesTheAttitudeAtCaptureTime) {
  // The vehicle yaws at 1 rad/s while hovering at p; fixes arrive 100 ms late. Rotating p_B with the
  // current attitude instead of the one at capture would misplace the fix by |p_B| * 0.1 rad ~ 0.17 m.
  Bench b;
  b.boot();
  calibrate(b);
  const Eigen::Vector3f p(0.8f, 0.6f, -1.5f);
  float yaw = 0.0f;
  std::vector<std::pair<uint64_t, Eigen::Quaternionf>> past;
  for (int i = 0; i < 300; ++i) {
    const Eigen::Quaternionf q(Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitZ()));
    past.emplace_back(b.t_us, q);
    b.hil_step(q, q.conjugate() * Eigen::Vector3f(0, 0, -kG), Eigen::Vector3f(0, 0, 1.0f));
    yaw += 0.01f;
    if (i > 20 && i % 3 == 0) {
      const auto& then = past[past.size() - 11];  // captured 100 ms ago
      b.landing_target(p, then.second, then.first);
    }
  }
  const quad::Vec3 est = b.app->position();
  EXPECT_NEAR(est.x, p.x(), 0.03f);
  EXPECT_NEAR(est.y, p.y(), 0.03f);
  EXPECT_NEAR(est.z, p.z(), 0.03f);
}

TEST(FirmwareApp, VisionPositionEstimateFeedsTheSameUpdate) {
  Bench b;
  b.boot();
  calibrate(b);
  const Eigen::Vector3f p(-0.7f, 1.2f, -2.0f);
  for (int i = 0; i < 150; ++i) {
    b.still_step();
    if (i % 3 == 0) {
      mav::VisionPositionEstimate v;
      v.usec = b.t_us - 30000;
      v.x = p.x();
      v.y = p.y();
      v.z = p.z();
      b.send(quad::hal::kUart2, v, b.vision);
    }
  }
  const quad::Vec3 est = b.app->position();
  EXPECT_NEAR(est.x, p.x(), 0.02f);
  EXPECT_NEAR(est.y, p.y(), 0.02f);
  EXPECT_NEAR(est.z, p.z(), 0.02f);
  EXPECT_GE(b.app->counters().fixes_fused, 45u);
}

TEST(FirmwareApp, AnswersTimesyncWithTheVehicleClock) {
  Bench b;
  b.boot();
  for (int i = 0; i < 5; ++i) b.still_step();
  mav::Timesync req;
  req.tc1 = 0;
  req.ts1 = 123456789;
  b.send(quad::hal::kUart2, req, b.vision);
  mav::Timesync answer;
  ASSERT_TRUE(b.last_timesync(&answer));
  EXPECT_EQ(answer.ts1, 123456789);
  EXPECT_EQ(answer.tc1, static_cast<int64_t>(b.t_us - 10000) * 1000) << "the last HIL time, in ns";
  // An answer from someone else (tc1 != 0) is not answered.
  const int frames = b.frames_on[quad::hal::kUart2];
  req.tc1 = 5;
  b.send(quad::hal::kUart2, req, b.vision);
  EXPECT_EQ(b.frames_on[quad::hal::kUart2], frames);
}

TEST(FirmwareApp, BadFixesAreCountedNotFused) {
  Bench b;
  b.boot();
  calibrate(b);
  mav::LandingTarget lt;
  lt.time_usec = b.t_us - 10000;
  lt.frame = mav::kFrameLocalNed;  // wrong frame
  lt.position_valid = 1;
  b.send(quad::hal::kUart2, lt, b.vision);
  lt.frame = mav::kFrameBodyFrd;
  lt.position_valid = 0;  // no position
  b.send(quad::hal::kUart2, lt, b.vision);
  lt.position_valid = 1;
  lt.time_usec = b.t_us - 2000000;  // older than the attitude history
  b.send(quad::hal::kUart2, lt, b.vision);
  EXPECT_EQ(b.app->counters().fixes_invalid, 2u);
  EXPECT_EQ(b.app->counters().fixes_rejected, 1u);
  EXPECT_EQ(b.app->counters().fixes_fused, 0u);
}

TEST(FirmwareApp, ParameterProtocolListReadSetAndPersist) {
  Bench b;
  b.boot();
  mav::ParamRequestList list;
  list.target_system = 1;
  b.send(quad::hal::kUart2, list, b.gcs);
  // One parameter in each iteration that sends no telemetry stream (22 of every 100 at the default rates).
  for (int i = 0; i < quad::fw::kParamCount * 100 / 78 + 5; ++i) b.still_step();
  ASSERT_EQ(b.params.size(), static_cast<size_t>(quad::fw::kParamCount)) << "one PARAM_VALUE per parameter";
  for (size_t i = 0; i < b.params.size(); ++i) {
    EXPECT_EQ(b.params[i].param_index, i);
    EXPECT_EQ(b.params[i].param_count, quad::fw::kParamCount);
    EXPECT_EQ(b.params[i].param_type, mav::kParamTypeReal32);
  }

  b.params.clear();
  b.set_param("POS_KP_Z", 2.5f, quad::hal::kUart2);
  ASSERT_EQ(b.params.size(), 1u);
  EXPECT_FLOAT_EQ(b.params[0].param_value, 2.5f);
  EXPECT_FLOAT_EQ(b.app->params().get(quad::fw::kPosKpZ), 2.5f);

  // Out of range: refused, the old value echoed, the reason said.
  b.set_param("POS_KP_Z", -1.0f, quad::hal::kUart2);
  ASSERT_EQ(b.params.size(), 2u);
  EXPECT_FLOAT_EQ(b.params[1].param_value, 2.5f);
  EXPECT_TRUE(b.said("param out of range: POS_KP_Z"));

  // Read by name (16 characters, no terminator) and by index.
  mav::ParamRequestRead read;
  read.target_system = 1;
  read.param_index = -1;
  std::memcpy(read.param_id, "FS_VIS_TIMEOUT\0\0", 16);
  b.send(quad::hal::kUart0, read, b.gcs);
  ASSERT_EQ(b.params.size(), 3u);
  EXPECT_FLOAT_EQ(b.params[2].param_value, 0.5f);
  read.param_index = quad::fw::kLoopHz;
  b.send(quad::hal::kUart0, read, b.gcs);
  EXPECT_FLOAT_EQ(b.params.back().param_value, 100.0f);

  // Reboot: the set value came back from the store.
  b.boot();
  EXPECT_EQ(b.app->store_status(), quad::fw::StoreStatus::kLoaded);
  EXPECT_FLOAT_EQ(b.app->params().get(quad::fw::kPosKpZ), 2.5f);

  // Corrupt one stored byte: defaults, and the vehicle says so.
  b.storage[20] ^= 0x10;
  b.texts.clear();
  b.boot();
  EXPECT_EQ(b.app->store_status(), quad::fw::StoreStatus::kCorrupt);
  EXPECT_FLOAT_EQ(b.app->params().get(quad::fw::kPosKpZ), 3.625f);
  EXPECT_TRUE(b.said("params: store corrupt, defaults"));
}

TEST(FirmwareApp, ParametersReconfigureTheTelemetryRates) {
  Bench b;
  b.boot();
  for (int i = 0; i < 100; ++i) b.still_step();
  const int base = b.frames_on[quad::hal::kUart2];
  for (const char* name : {"TEL_ATT_HZ", "TEL_POS_HZ", "TEL_SYS_HZ", "TEL_HB_HZ", "TEL_EST_HZ"}) b.set_param(name, 0.0f);
  const int after_set = b.frames_on[quad::hal::kUart2];
  for (int i = 0; i < 100; ++i) b.still_step();
  EXPECT_GT(base, 20) << "defaults: attitude and position at 10 Hz, heartbeat and status at 1 Hz";
  EXPECT_EQ(b.frames_on[quad::hal::kUart2], after_set) << "all streams off: nothing more on the radio";
}

// Brings a calibrated, armed vehicle into AUTO with fresh fixes (hovering still at p).
void into_auto(Bench& b, const Eigen::Vector3f& p) {
  calibrate(b);
  quad::fw::test::ready_to_arm(b);
  b.sticks(0);
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  for (int i = 0; i < 30; ++i) {
    b.still_step();
    if (i % 3 == 0) b.landing_target(p, Eigen::Quaternionf::Identity(), b.t_us - 30000);
    if (i % 5 == 0) b.sticks(0);
  }
  ASSERT_EQ(b.set_mode(FlightMode::kAuto), mav::kResultAccepted);
  EXPECT_EQ(b.app->mode(), FlightMode::kAuto);
}

TEST(FirmwareApp, RcSwitchesArmKillAndSelectTheMode) {
  // Thesis sec. 6.1.4: a motor-enable toggle and a manual/auto toggle (MANUAL_CONTROL buttons bits 0/1).
  Bench b;
  b.boot();
  b.set_param("RC_SWITCHES", 1.0f);
  calibrate(b);
  const Eigen::Vector3f p(0, 0, -1.0f);
  auto fly = [&](int steps, uint16_t buttons, int16_t throttle = 0) {
    for (int i = 0; i < steps; ++i) {
      b.still_step();
      if (i % 3 == 0) b.landing_target(p, Eigen::Quaternionf::Identity(), b.t_us - 20000);
      b.sticks(throttle, buttons);
    }
  };
  fly(5, 0x1);
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed) << "a switch found on at power-up does not arm";
  fly(5, 0x0);
  fly(5, 0x1);
  EXPECT_EQ(b.app->mode(), FlightMode::kManual) << "off -> on arms";
  EXPECT_TRUE(b.said("MANUAL: armed"));
  fly(5, 0x3);
  EXPECT_EQ(b.app->mode(), FlightMode::kAuto);
  fly(5, 0x1);
  EXPECT_EQ(b.app->mode(), FlightMode::kManual);
  fly(5, 0x1, 600);  // throttle up: in flight as far as the land detector can tell
  EXPECT_EQ(b.command(mav::kCmdComponentArmDisarm, 0.0f), mav::kResultDenied) << "a plain disarm is refused";
  fly(5, 0x0, 600);  // the kill switch disarms at once, in the air too
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);
  EXPECT_TRUE(b.said("DISARMED: disarmed"));
}

TEST(FirmwareApp, RcSwitchesIgnoredUnlessEnabled) {
  Bench b;
  b.boot();
  calibrate(b);
  for (uint16_t buttons : {0, 1, 0, 1, 3}) {
    b.sticks(0, buttons);
    b.still_step();
  }
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);
}

TEST(FirmwareApp, AutoRefusedWithoutVision) {
  Bench b;
  b.boot();
  calibrate(b);
  quad::fw::test::ready_to_arm(b);
  b.sticks(0);
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  EXPECT_EQ(b.set_mode(FlightMode::kAuto), mav::kResultDenied);
  EXPECT_TRUE(b.said("auto refused: no vision fix"));
}

TEST(FirmwareApp, FailsafeVisionLostLandsLevel) {
  Bench b;
  b.boot();
  into_auto(b, Eigen::Vector3f(0, 0, -1.5f));
  // Fixes stop; RC keeps coming. 0.5 s later the vehicle lands, level.
  for (int i = 0; i < 45; ++i) {
    b.still_step();
    if (i % 5 == 0) b.sticks(0);
  }
  EXPECT_EQ(b.app->mode(), FlightMode::kAuto);
  for (int i = 0; i < 10; ++i) b.still_step();
  EXPECT_EQ(b.app->mode(), FlightMode::kLanding);
  EXPECT_TRUE(b.said("LANDING: FAILSAFE vision lost: level, land"));
}

TEST(FirmwareApp, FailsafeRcLostLands) {
  Bench b;
  b.boot();
  calibrate(b);
  quad::fw::test::ready_to_arm(b);
  b.sticks(0);
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  for (int i = 0; i < 95; ++i) b.still_step();
  EXPECT_EQ(b.app->mode(), FlightMode::kManual);
  for (int i = 0; i < 10; ++i) b.still_step();
  // On the ground the landing is over at once: LANDING, then DISARMED, both reported in that order.
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);
  const auto landing = std::find(b.texts.begin(), b.texts.end(), "LANDING: FAILSAFE RC lost: land");
  ASSERT_NE(landing, b.texts.end());
  EXPECT_NE(std::find(landing, b.texts.end(), "DISARMED: landed, disarmed"), b.texts.end());
}

TEST(FirmwareApp, NoRcFailsafeWhenRcIsNotRequired) {
  Bench b;
  b.boot();
  b.set_param("FS_RC_ENABLE", 0.0f);
  calibrate(b);
  quad::fw::test::ready_to_arm(b);
  ASSERT_EQ(b.arm(), mav::kResultAccepted) << "arming without any RC";
  for (int i = 0; i < 300; ++i) b.still_step();
  EXPECT_EQ(b.app->mode(), FlightMode::kManual);
}


TEST(FirmwareApp, TakesOffInAutoLandsAndDisarms) {
  Bench b;
  b.gyro_bias.setZero();
  b.boot();
  VerticalFlight flight(b);
  const VerticalVehicle& v = flight.v;
  into_auto(b, Eigen::Vector3f(0, 0, 0));
  // Climb to 1.5 m.
  b.position_target(-1.5f);
  auto fly = [&](int steps) { flight.fly(steps); };
  fly(800);
  EXPECT_NEAR(v.z, -1.5f, 0.1f) << "AUTO reaches the setpoint";
  EXPECT_NEAR(b.app->position().z, v.z, 0.05f);
  EXPECT_EQ(b.command(mav::kCmdComponentArmDisarm, 0.0f), mav::kResultDenied) << "no disarm in flight";
  EXPECT_TRUE(b.said("disarm refused: in flight"));
  ASSERT_EQ(b.command(mav::kCmdNavLand), mav::kResultAccepted);
  EXPECT_EQ(b.app->mode(), FlightMode::kLanding);
  fly(1000);
  EXPECT_NEAR(v.z, 0.0f, 1e-3f) << "on the ground";
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);
  EXPECT_TRUE(b.said("DISARMED: landed, disarmed"));
  for (int i = 0; i < 4; ++i) EXPECT_EQ(b.actuators.back().controls[i], 0.0f);
}

// The bench booted at rate_hz (SYS_LOOP_HZ and the step period), in AUTO, asked to climb to 1.5 m.
void auto_at_rate(Bench& b, float rate_hz) {
  b.gyro_bias.setZero();
  b.boot();
  ASSERT_EQ(b.app->override_param(quad::fw::kLoopHz, rate_hz), nullptr);
  b.step_us = static_cast<uint32_t>(1e6f / rate_hz + 0.5f);
  into_auto(b, Eigen::Vector3f(0, 0, 0));
  b.position_target(-1.5f);
}

// SYS_LOOP_HZ 400: the attitude propagation and the attitude loop in every iteration, the observer's
// correction, the filter's prediction and the position loop each in one of four (docs/firmware.md). The
// flight still works (take-off, hold, landing), the motors answer a body rate in the very iteration it
// is measured, and the thrust the position loop asks for changes on one iteration in four only.
TEST(FirmwareApp, At400HzTheAttitudeLoopRunsEveryIterationAndThePositionLoopOneInFour) {
  Bench b;
  ASSERT_NO_FATAL_FAILURE(auto_at_rate(b, 400.0f));
  VerticalFlight flight(b);
  const VerticalVehicle& v = flight.v;
  auto collective = [&] {
    float c = 0.0f;
    for (int i = 0; i < 4; ++i) c += b.actuators.back().controls[i] * b.actuators.back().controls[i];
    return c;
  };
  int iterations = 0, collective_changes = 0;
  auto fly = [&](int steps) {
    for (int i = 0; i < steps; ++i) {
      const float before = b.actuators.empty() ? 0.0f : collective();
      flight.step(i);
      ++iterations;
      if (collective() != before) ++collective_changes;
    }
  };
  fly(3200);  // 8 s
  EXPECT_NEAR(v.z, -1.5f, 0.1f) << "AUTO reaches the setpoint at 400 Hz";
  EXPECT_NEAR(b.app->position().z, v.z, 0.05f);
  // The attitude loop's thrust shares sum to the held thrust, so the collective moves only when the
  // position loop runs: about one iteration in four (the mixer's rounding can repeat a value).
  EXPECT_LE(collective_changes, iterations / 4 + 2);
  EXPECT_GE(collective_changes, iterations / 5);
  // A roll rate in one iteration: the motors answer in that iteration (the rate term of eq. 8.39),
  // whichever of the four it is.
  for (int k = 0; k < 4; ++k) {
    const auto before = b.actuators.back();
    b.hil_step(Eigen::Quaternionf::Identity(), Eigen::Vector3f(0, 0, flight.f_z), Eigen::Vector3f(0.5f, 0.0f, 0.0f));
    const auto& after = b.actuators.back();
    // Plus frame (control/vehicle.h): motors 1 (left) and 3 (right) carry roll; a positive roll rate
    // is damped by a negative roll torque: more thrust on the right, less on the left.
    EXPECT_LT(after.controls[1] - after.controls[3], before.controls[1] - before.controls[3] - 1e-3f) << "iteration " << k;
    for (int i = 0; i < 20; ++i) flight.step(i, Eigen::Vector3f::Zero(), false);
    b.hil_step(Eigen::Quaternionf::Identity(), Eigen::Vector3f(0, 0, flight.f_z));  // the next try one iteration later
  }
  ASSERT_EQ(b.command(mav::kCmdNavLand), mav::kResultAccepted);
  fly(4000);
  EXPECT_NEAR(v.z, 0.0f, 1e-3f) << "on the ground";
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed);
}

// Above 100 Hz a vision fix is not fused where it arrives: the frame-rate work's iteration takes its
// gate in the next frame and its update in the one after (docs/performance.md, "The 400 Hz frame"), so
// the estimate moves to it 5 to 8 iterations after its arrival, all at once; at 100 Hz at once.
TEST(FirmwareApp, AboveTheThesisRateAVisionFixIsFusedOverTheNextTwoFrames) {
  for (const float rate : {400.0f, 200.0f, 100.0f}) {
    Bench b;
    ASSERT_NO_FATAL_FAILURE(auto_at_rate(b, rate));
    VerticalFlight flight(b);
    flight.fly_seconds(6.0f);
    for (int i = 0; i < 40; ++i) flight.step(i, Eigen::Vector3f::Zero(), false);  // nothing in progress
    const uint32_t fused = b.app->counters().fixes_fused;
    // 4 cm below the vehicle: the estimate steps down when the fix is fused (K_p of about 0.9). Step -1
    // is the fix's arrival itself (the bench hands the frame to the firmware at once).
    float z = b.app->position().z;
    b.landing_target(Eigen::Vector3f(0, 0, flight.v.z + 0.04f), Eigen::Quaternionf::Identity(), b.t_us - b.step_us);
    int fused_after = -2;
    float step_at_fusion = 0.0f, largest_other_step = 0.0f;
    for (int i = -1; i < 12; ++i) {
      if (i >= 0) flight.step(i, Eigen::Vector3f::Zero(), false);
      const float dz = b.app->position().z - z;
      z = b.app->position().z;
      if (fused_after < -1 && b.app->counters().fixes_fused == fused + 1) {
        fused_after = i;
        step_at_fusion = dz;
      } else {
        largest_other_step = std::max(largest_other_step, std::abs(dz));
      }
    }
    EXPECT_EQ(b.app->counters().fixes_fused, fused + 1) << rate;
    if (rate > 100.0f) {
      // n iterations per frame: the gate in the first frame-rate iteration (0..n-1 after the arrival), the
      // update n later.
      const int n = static_cast<int>(rate / 100.0f);
      EXPECT_GE(fused_after, n) << rate << ": the gate in the next frame-rate iteration, the update a frame later";
      EXPECT_LE(fused_after, 2 * n - 1) << rate;
    } else {
      EXPECT_EQ(fused_after, -1) << "fused where it arrives";
    }
    EXPECT_GT(step_at_fusion, 0.02f) << rate;  // NED: down is +z
    EXPECT_LT(largest_other_step, 0.25f * step_at_fusion) << rate;
  }
}

// The application's own output is spread: at 200 Hz, hovering with 30 Hz fixes while a parameter list
// streams, no iteration sends more than one telemetry stream or streamed parameter, and the iteration
// that fuses a fix (its update step) sends neither; the list and the streams' rates still complete.
TEST(FirmwareApp, OneStreamOrParameterPerIterationAndNoneBesideAFixStep) {
  Bench b;
  ASSERT_NO_FATAL_FAILURE(auto_at_rate(b, 200.0f));
  VerticalFlight flight(b);
  flight.fly_seconds(4.0f);
  mav::ParamRequestList list;
  list.target_system = 1;
  b.send(quad::hal::kUart0, list, b.gcs);
  const uint32_t ids[5] = {mav::Heartbeat::kId, mav::AttitudeQuaternion::kId, mav::LocalPositionNed::kId,
                           mav::SysStatus::kId, mav::ParamValue::kId};
  auto sent = [&] {
    int n = 0;
    for (const uint32_t id : ids) n += b.count_on(quad::hal::kUart0, id);
    return n;
  };
  const size_t params_before = b.params.size();
  const int attitude_before = b.count_on(quad::hal::kUart0, mav::AttitudeQuaternion::kId);
  int fix_steps = 0, busiest = 0;
  for (int i = 0; i < 400; ++i) {  // 2 s
    const int before = sent();
    const uint32_t fused = b.app->counters().fixes_fused;
    flight.step(i);
    const int frames = sent() - before;
    busiest = std::max(busiest, frames);
    if (b.app->counters().fixes_fused != fused) {
      ++fix_steps;
      EXPECT_EQ(frames, 0) << "iteration " << i << " fused a fix and sent " << frames << " frames";
    }
  }
  EXPECT_EQ(busiest, 1) << "at most one stream or parameter per iteration";
  EXPECT_GE(fix_steps, 50) << "fixes fused in the frame-rate iterations (30 Hz for 2 s)";
  EXPECT_EQ(b.params.size() - params_before, static_cast<size_t>(quad::fw::kParamCount)) << "the whole list";
  EXPECT_NEAR(b.count_on(quad::hal::kUart0, mav::AttitudeQuaternion::kId) - attitude_before, 20, 1) << "10 Hz";
}

// A fix waiting whenever the last one is done (a camera faster than the station's 30 Hz) would keep the
// frame-rate work's iteration busy with fixes in every frame at 400 Hz; it gives way at most twice in a
// row, so the landing detection and the failsafes still run: a landing commanded under that stream of
// fixes ends disarmed.
TEST(FirmwareApp, At400HzFastVisionFixesDoNotStarveTheFrameRateWork) {
  Bench b;
  ASSERT_NO_FATAL_FAILURE(auto_at_rate(b, 400.0f));
  VerticalFlight flight(b);
  flight.fly_seconds(6.0f);
  ASSERT_NEAR(flight.v.z, -1.5f, 0.1f);
  const uint32_t fused = b.app->counters().fixes_fused, rejected = b.app->counters().fixes_rejected;
  ASSERT_EQ(b.command(mav::kCmdNavLand), mav::kResultAccepted);
  uint32_t sent_at_fused = 0xFFFFFFFFu;
  for (int i = 0; i < 4000; ++i) {  // 10 s
    flight.step(i, Eigen::Vector3f::Zero(), false);
    const uint32_t now_fused = b.app->counters().fixes_fused;
    if (now_fused != sent_at_fused || i % 8 == 0) {  // the next fix as soon as one is taken, and every 20 ms
      b.landing_target(Eigen::Vector3f(0, 0, flight.v.z), Eigen::Quaternionf::Identity(), b.t_us - b.step_us);
      sent_at_fused = now_fused;
    }
    if (i % 20 == 0) b.sticks(0);
  }
  EXPECT_NEAR(flight.v.z, 0.0f, 1e-3f) << "on the ground";
  EXPECT_EQ(b.app->mode(), FlightMode::kDisarmed) << "landing detected";
  const uint32_t fused_now = b.app->counters().fixes_fused - fused, refused = b.app->counters().fixes_rejected - rejected;
  std::cout << "[figure] a fix always waiting at 400 Hz, 10 s: " << fused_now << " fused, " << refused << " refused\n";
  EXPECT_GE(fused_now, 300u) << "30 Hz of them still fused";
  EXPECT_GT(refused, 0u) << "the others refused while one is in progress";
}

// SYS_LOOP_HZ changed in flight (a PARAM_SET while hovering): the stage clock starts a new frame, the
// observer moves between its single-rate and multi-rate forms, and the position loop goes on: after
// each change the vehicle moves 30 cm to a new height and holds it.
TEST(FirmwareApp, ChangingTheLoopRateInFlightKeepsThePositionLoop) {
  Bench b;
  ASSERT_NO_FATAL_FAILURE(auto_at_rate(b, 100.0f));
  VerticalFlight flight(b);
  const VerticalVehicle& v = flight.v;
  auto fly = [&](float seconds) { flight.fly_seconds(seconds); };
  fly(8.0f);  // at 100 Hz: climbed and settled
  ASSERT_NEAR(v.z, -1.5f, 0.05f);
  float target = -1.5f;
  for (const float hz : {400.0f, 200.0f, 100.0f, 400.0f}) {
    ASSERT_EQ(b.app->override_param(quad::fw::kLoopHz, hz), nullptr);
    b.step_us = static_cast<uint32_t>(1e6f / hz + 0.5f);
    target = target < -1.35f ? -1.2f : -1.5f;
    b.position_target(target);
    fly(6.0f);
    std::printf("[figure] loop rate changed in flight to %.0f Hz, then a 30 cm move: %.1f mm from the target after 6 s\n",
                hz, std::fabs(v.z - target) * 1000.0f);
    EXPECT_NEAR(v.z, target, 0.03f) << hz << " Hz";
    EXPECT_EQ(b.app->mode(), FlightMode::kAuto) << hz << " Hz";
    EXPECT_NEAR(b.app->position().z, v.z, 0.02f) << hz << " Hz";
  }
}

}  // namespace

namespace {

// Every message type the application reads, with random bytes in every field (NaN, infinities, huge
// counts, unterminated names), interleaved with HIL steps: nothing may crash (this also runs under
// AddressSanitizer / UBSan in the host-debug preset) and the motor commands must stay in [0, 1].
// Hovers a vehicle 5 % heavier than the airframe parameters say at 1 m in AUTO for `seconds`; returns
// the mean height error (true z - setpoint, NED) over the last 2 s.
float hover_offset_with_heavier_vehicle(float ki, float seconds, float* trim = nullptr) {
  Bench b;
  b.gyro_bias.setZero();
  b.boot();
  EXPECT_EQ(b.app->override_param(quad::fw::kPosKiZ, ki), nullptr);
  VerticalFlight flight(b);
  const VerticalVehicle& v = flight.v;
  flight.v.mass = 1.4f * 1.05f;
  into_auto(b, Eigen::Vector3f(0, 0, 0));
  b.position_target(-1.0f);
  const int steps = static_cast<int>(seconds * 100.0f);
  double sum = 0.0;
  int n = 0;
  for (int i = 0; i < steps; ++i) {
    flight.step(i);
    if (i >= steps - 200) {
      sum += v.z - (-1.0f);
      ++n;
    }
  }
  EXPECT_EQ(b.app->mode(), FlightMode::kAuto);
  if (trim != nullptr) *trim = b.app->hover_trim();
  return static_cast<float>(sum / n);
}

TEST(FirmwareApp, HoverTrimRemovesTheOffsetOfAFivePercentMassMismatch) {
  // Without the trim eq. 8.20 settles where K_p,z tanh(e) = 5 % of g: e = 0.135 m low.
  const float untrimmed = hover_offset_with_heavier_vehicle(0.0f, 20.0f);
  EXPECT_NEAR(untrimmed, 0.135f, 0.02f) << "the PD law's offset, positive = below the setpoint";
  float trim = 0.0f;
  const float trimmed = hover_offset_with_heavier_vehicle(1.0f, 20.0f, &trim);
  EXPECT_LT(std::fabs(trimmed), 0.01f) << "the trim removes it within 20 s";
  // The learned feed-forward is the missing 5 % of thrust: 0.05 g up (negative in NED).
  EXPECT_NEAR(trim, -0.05f * kG, 0.05f);
  std::printf("5 %% heavier vehicle at 1 m: offset %.1f mm without the trim, %.2f mm with it (trim %.3f m/s^2)\n",
              untrimmed * 1000.0f, trimmed * 1000.0f, trim);
}

TEST(PositionTrim, IntegratesWithTheRightSignAndStopsAtTheLimit) {
  quad::fw::AxisTrim t;
  t.update(0.1f, 0.5f, 1.0f, 2.0f);  // 10 cm low (NED z larger than the setpoint): more thrust = negative a_d,z
  EXPECT_FLOAT_EQ(t.accel(), -0.05f);
  for (int i = 0; i < 1000; ++i) t.update(1.0f, 0.1f, 1.0f, 2.0f);
  EXPECT_FLOAT_EQ(t.accel(), -2.0f) << "clamped";
  t.update(-0.1f, 1.0f, 1.0f, 2.0f);
  EXPECT_FLOAT_EQ(t.accel(), -1.9f) << "unwinds at once from the limit (no hidden wind-up)";
  t.update(-5.0f, 1.0f, 1.0f, 2.0f);
  EXPECT_FLOAT_EQ(t.accel(), -1.7f) << "a 5 m error is learned as 0.2 m (a transient, not an offset)";
  t.update(NAN, 0.1f, 1.0f, 2.0f);
  EXPECT_FLOAT_EQ(t.accel(), -1.7f) << "a non-finite error changes nothing";
  t.clamp(0.5f);
  EXPECT_FLOAT_EQ(t.accel(), -0.5f) << "a smaller limit clamps the held value";
  t.update(1.0f, 1.0f, 0.0f, 0.5f);
  EXPECT_FLOAT_EQ(t.accel(), -0.5f) << "gain 0: held, no learning";
}

TEST(PositionTrim, HorizontalAndVerticalAxesHaveTheirOwnGainsAndFreezeWhenAsked) {
  quad::fw::PositionTrim t;
  t.configure(0.5f, 1.0f, 2.0f, 3.0f);
  const bool all[3] = {true, true, true};
  t.update(quad::Vec3{0.2f, -0.1f, 0.1f}, all, 1.0f);  // north of, west of and below the setpoint
  EXPECT_FLOAT_EQ(t.accel().x, -0.1f) << "pushes back south";
  EXPECT_FLOAT_EQ(t.accel().y, 0.05f) << "pushes back east";
  EXPECT_FLOAT_EQ(t.accel_z(), -0.2f) << "more thrust, with the vertical gain";
  const bool only_z[3] = {false, false, true};
  t.update(quad::Vec3{5.0f, 5.0f, 0.0f}, only_z, 1.0f);
  EXPECT_FLOAT_EQ(t.accel().x, -0.1f) << "frozen axes hold their value";
  EXPECT_FLOAT_EQ(t.accel().y, 0.05f);
  for (int i = 0; i < 50; ++i) t.update(quad::Vec3{10.0f, -10.0f, 10.0f}, all, 1.0f);
  EXPECT_FLOAT_EQ(t.accel().x, -1.0f) << "horizontal limit";
  EXPECT_FLOAT_EQ(t.accel().y, 1.0f);
  EXPECT_FLOAT_EQ(t.accel_z(), -3.0f) << "vertical limit";
  t.configure(0.5f, 0.4f, 2.0f, 3.0f);
  EXPECT_FLOAT_EQ(t.accel().x, -0.4f) << "a new horizontal limit clamps x and y, not z";
  EXPECT_FLOAT_EQ(t.accel().y, 0.4f);
  EXPECT_FLOAT_EQ(t.accel_z(), -3.0f);
  t.reset();
  EXPECT_FLOAT_EQ(t.accel().x, 0.0f);
  EXPECT_FLOAT_EQ(t.accel_z(), 0.0f);
}

TEST(FirmwareApp, SurvivesRandomFieldsInEveryMessage) {
  Bench b;
  b.boot();
  std::mt19937 rng(11);
  auto randomize = [&](auto& msg) {
    uint8_t* bytes = reinterpret_cast<uint8_t*>(&msg);
    for (size_t i = 0; i < sizeof msg; ++i) bytes[i] = static_cast<uint8_t>(rng());
  };
  auto send_random = [&](auto msg, uint8_t port) {
    randomize(msg);
    b.send(port, msg, b.gcs);
  };
  for (int i = 0; i < 3000; ++i) {
    b.still_step();
    const uint8_t port = static_cast<uint8_t>(rng() % 2);
    switch (rng() % 10) {
      case 0: {  // real command ids and target, random parameters
        mav::CommandLong c;
        randomize(c);
        const uint16_t ids[] = {mav::kCmdComponentArmDisarm, mav::kCmdDoSetMode, mav::kCmdNavLand, c.command};
        c.command = ids[rng() % 4];
        c.target_system = 1;
        b.send(port, c, b.gcs);
        break;
      }
      case 1: {  // real names, random bit patterns as values
        mav::ParamSet set;
        randomize(set);
        set.target_system = 1;
        std::memcpy(set.param_id, quad::fw::param_info(static_cast<uint8_t>(rng() % quad::fw::kParamCount)).name, 16);
        b.send(port, set, b.gcs);
        break;
      }
      case 2: send_random(mav::ParamRequestRead{}, port); break;
      case 3: send_random(mav::ParamRequestList{}, port); break;
      case 4: send_random(mav::SetPositionTargetLocalNed{}, port); break;
      case 5: send_random(mav::ManualControl{}, port); break;
      case 6: send_random(mav::LandingTarget{}, port); break;
      case 7: send_random(mav::VisionPositionEstimate{}, port); break;
      case 8: send_random(mav::Timesync{}, port); break;
      default: send_random(mav::HilSensor{}, port); break;  // garbage sensor data, even a wild clock
    }
    for (float u : b.app->motors()) {
      ASSERT_TRUE(std::isfinite(u));
      ASSERT_GE(u, 0.0f);
      ASSERT_LE(u, 1.0f);
    }
  }
  EXPECT_GT(b.app->counters().iterations, 3000u);
  // The parameters still hold values within their ranges.
  for (uint8_t i = 0; i < quad::fw::kParamCount; ++i) {
    const quad::fw::ParamInfo info = quad::fw::param_info(i);
    EXPECT_GE(b.app->params().get(i), info.min) << info.name;
    EXPECT_LE(b.app->params().get(i), info.max) << info.name;
  }
}

}  // namespace

// The trim's clamps compare bit patterns and PositionTrim tests dt once: against the float code it
// replaced (written out here), the held accelerations must be bit-identical for random errors (inside
// and beyond the 0.2 m clamp, exactly at it, NaN, infinite), learn flags, steps (0, negative, NaN,
// infinite) and limits (0, in range, NaN, negative: the clampf fallback).
namespace {

float reference_axis(float accel, float e_in, float dt, float ki, float limit) {
  if (!quad::is_finite(e_in) || !(dt > 0.0f)) return accel;
  const float e = quad::clampf(e_in, -quad::fw::AxisTrim::kMaxLearnedError, quad::fw::AxisTrim::kMaxLearnedError);
  return quad::clampf(accel - ki * e * dt, -limit, limit);
}

}  // namespace

TEST(PositionTrim, BitPatternClampsMatchTheFloatImplementation) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> err(-0.5f, 0.5f), gain(0.0f, 5.0f);
  const float dts[] = {0.01f, 0.0025f, 0.0f, -0.01f, nan, inf, 1e-30f};
  const float limits[] = {2.0f, 0.0f, 0.05f, 5.0f, -1.0f, nan, inf, -0.0f};
  for (float limit : limits) {
    const float ki_xy = gain(rng), ki_z = gain(rng);
    quad::fw::PositionTrim t;
    t.configure(ki_xy, limit, ki_z, limit);
    float ref[3] = {t.accel().x, t.accel().y, t.accel().z};
    quad::fw::AxisTrim single;
    float ref_single = single.accel();
    for (int i = 0; i < 20000; ++i) {
      auto pick = [&]() {
        switch (rng() % 10) {
          case 0: return 0.2f;
          case 1: return -0.2f;
          case 2: return nan;
          case 3: return (rng() % 2) ? inf : -inf;
          default: return err(rng);
        }
      };
      const quad::Vec3 e{pick(), pick(), pick()};
      const bool learn[3] = {rng() % 4 != 0, rng() % 4 != 0, rng() % 4 != 0};
      const float dt = (rng() % 8 == 0) ? dts[rng() % 7] : 0.01f;
      t.update(e, learn, dt);
      const float ki[3] = {ki_xy, ki_xy, ki_z};
      for (int a = 0; a < 3; ++a) {
        if (learn[a]) ref[a] = reference_axis(ref[a], e[a], dt, ki[a], limit);
      }
      ASSERT_EQ(bits_of(t.accel().x), bits_of(ref[0])) << "limit " << limit << " step " << i;
      ASSERT_EQ(bits_of(t.accel().y), bits_of(ref[1])) << "limit " << limit << " step " << i;
      ASSERT_EQ(bits_of(t.accel().z), bits_of(ref[2])) << "limit " << limit << " step " << i;
      single.update(e.x, dt, ki_xy, limit);
      ref_single = reference_axis(ref_single, e.x, dt, ki_xy, limit);
      ASSERT_EQ(bits_of(single.accel()), bits_of(ref_single)) << "limit " << limit << " step " << i;
    }
  }
}
