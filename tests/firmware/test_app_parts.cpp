// The flight application's parts on their own, without MAVLink bytes: the frame schedule's multi-rate
// policy, the state estimator from the boot calibration to a fused fix, and flight control from arming
// to a landing.
#include <gtest/gtest.h>

#include <cmath>

#include "quad/firmware/flight_control.h"
#include "quad/firmware/frame_schedule.h"
#include "quad/firmware/params.h"
#include "quad/firmware/state_estimator.h"

namespace {

using quad::Vec3;
using quad::fw::FrameSchedule;
using quad::fw::IterationPlan;

constexpr float kG = 9.80665f;

// At 100 Hz every iteration runs every stage, the frame-rate work over one period, and a fix is fused
// where it arrives.
TEST(FrameSchedule, AtTheThesisRateEveryIterationRunsEveryStage) {
  FrameSchedule s;
  s.configure(100.0f);
  EXPECT_TRUE(s.fuses_on_arrival());
  for (int i = 0; i < 50; ++i) {
    const IterationPlan p = s.next(0.01f, false);
    EXPECT_TRUE(p.correct && p.predict && p.position_loop && p.frame_work);
    EXPECT_FALSE(p.multi_rate || p.fix_step);
    EXPECT_FLOAT_EQ(p.correction_dt, 0.01f);
    EXPECT_FLOAT_EQ(p.frame_dt, 0.01f);
  }
}

// A fix is fused where it arrives only when one iteration holds every stage; with two or more per frame
// it is queued for the frame-rate work's iteration.
TEST(FrameSchedule, AFixIsFusedOnArrivalOnlyAtOneIterationPerFrame) {
  FrameSchedule s;
  for (const float hz : {50.0f, 100.0f, 150.0f, 199.0f}) {
    s.configure(hz);
    EXPECT_TRUE(s.fuses_on_arrival()) << hz;
  }
  for (const float hz : {200.0f, 250.0f, 300.0f, 400.0f, 1000.0f}) {
    s.configure(hz);
    EXPECT_FALSE(s.fuses_on_arrival()) << hz;
  }
}

// At 400 Hz each stage has an iteration of its own, once per frame, and the correction and the frame-rate
// work are handed the whole frame's time.
TEST(FrameSchedule, At400HzEachStageOncePerFrameWithTheFramesTime) {
  FrameSchedule s;
  s.configure(400.0f);
  EXPECT_FALSE(s.fuses_on_arrival());
  int runs[4] = {0, 0, 0, 0};
  for (int i = 0; i < 400; ++i) {
    const IterationPlan p = s.next(0.0025f, false);
    EXPECT_TRUE(p.multi_rate);
    EXPECT_LE(int(p.correct) + int(p.predict) + int(p.position_loop) + int(p.frame_work), 1) << i;
    runs[0] += p.correct;
    runs[1] += p.predict;
    runs[2] += p.position_loop;
    runs[3] += p.frame_work;
    if (i >= 4 && p.correct) EXPECT_NEAR(p.correction_dt, 0.01f, 1e-6f);
    if (i >= 4 && p.frame_work) EXPECT_NEAR(p.frame_dt, 0.01f, 1e-6f);
  }
  for (int stage = 0; stage < 4; ++stage) EXPECT_NEAR(runs[stage], 100, 1) << stage;
}

// A fix waiting takes the frame-rate work's iteration at most twice in a row; the work then runs over
// the three frames' time.
TEST(FrameSchedule, AFixGivesTheFrameWorkBackAfterTwoFrames) {
  FrameSchedule s;
  s.configure(400.0f);
  for (int i = 0; i < 8; ++i) s.next(0.0025f, false);  // two whole frames
  int fix_steps = 0, work = 0;
  float work_dt = 0.0f;
  for (int i = 0; i < 12; ++i) {  // three frames with a fix always waiting
    const IterationPlan p = s.next(0.0025f, true);
    fix_steps += p.fix_step;
    if (p.frame_work) {
      ++work;
      work_dt = p.frame_dt;
    }
    EXPECT_FALSE(p.fix_step && p.frame_work);
  }
  EXPECT_EQ(fix_steps, 2);
  EXPECT_EQ(work, 1);
  EXPECT_NEAR(work_dt, 0.03f, 1e-6f);
}

// The estimator at 100 Hz on a level, still vehicle heading north: the samples of the boot calibration.
struct LevelAndStill {
  quad::fw::StateEstimator est;
  FrameSchedule schedule;
  quad::hal::ImuSample imu;
  quad::hal::MagSample mag;
  uint32_t t_us = 0;
  explicit LevelAndStill(const quad::fw::Params& params) {
    est.configure(params, 100.0f);
    est.restart_calibration();
    schedule.configure(100.0f);
    imu.accel = Vec3{0.0f, 0.0f, -kG};
    mag.field = Vec3{0.2f, 0.0f, 0.45f};
  }
  quad::fw::EstimatorEvent step() {
    const quad::fw::EstimatorEvent e = est.step(t_us, imu, &mag, 0.01f, schedule.next(0.01f, false), false, false);
    t_us += 10000;
    return e;
  }
};

// Level and still for the boot calibration, then a fix: the estimator calibrates, converges, and takes
// the fix's position, all from samples and parameters.
TEST(StateEstimator, CalibratesConvergesAndTakesAFix) {
  quad::fw::Params params;
  LevelAndStill still(params);
  quad::fw::StateEstimator& est = still.est;
  ASSERT_EQ(est.check(params), nullptr);
  bool calibrated = false;
  for (int i = 0; i < 400 && !calibrated; ++i) calibrated = still.step() == quad::fw::EstimatorEvent::kCalibrated;
  ASSERT_TRUE(calibrated);
  EXPECT_TRUE(est.converged());
  for (int i = 0; i < 20; ++i) still.step();
  EXPECT_TRUE(est.healthy());
  const uint32_t t_us = still.t_us;
  EXPECT_NEAR(std::fabs(est.attitude().w), 1.0f, 1e-4f) << "level, heading north";
  // The star 1.5 m below, seen 30 ms ago: the vehicle 1.5 m above it.
  Vec3 p;
  ASSERT_TRUE(est.position_from_star(Vec3{0.0f, 0.0f, 1.5f}, t_us - 30000, &p));
  EXPECT_NEAR(p.z, -1.5f, 1e-4f);
  const quad::est::FixResult r = est.fuse_fix(p, t_us - 30000);
  EXPECT_TRUE(r == quad::est::FixResult::kInitialized || r == quad::est::FixResult::kFused);
  EXPECT_NEAR(est.position().z, -1.5f, 0.01f);
}

// The star's attitude into the thesis pair's observer (EST_STAR_ATT, docs/estimation.md, "The star's
// attitude in the thesis pair"): a level vehicle, calibrated, and a fix captured 30 ms ago that says it is
// rolled 2 deg and turned 5 deg.
struct StarAttitudeCase {
  quad::Euler before, after;
};

StarAttitudeCase star_attitude_case(float est_star_att, const float q_bs[4], const float* att_cov) {
  quad::fw::Params params;
  EXPECT_EQ(params.set(quad::fw::kEstStarAtt, est_star_att), quad::fw::ParamError::kNone);
  LevelAndStill still(params);
  quad::fw::StateEstimator& est = still.est;
  for (int i = 0; i < 420; ++i) still.step();
  const uint32_t t_us = still.t_us;
  EXPECT_TRUE(est.converged());
  if (att_cov != nullptr) est.attach_covariance(t_us - 30000, att_cov, att_cov, true);
  StarAttitudeCase c;
  c.before = quad::to_euler(est.attitude());
  est.star_attitude(q_bs, t_us - 30000);
  c.after = quad::to_euler(est.attitude());
  return c;
}

TEST(StateEstimator, TakesTheStarsAttitudeAsEstStarAttSays) {
  const quad::Quat q_ib = quad::from_euler(quad::Euler{0.0349f, 0.0f, 0.0873f});  // roll 2 deg, yaw 5 deg
  const float q_bs[4] = {q_ib.w, -q_ib.x, -q_ib.y, -q_ib.z};                     // q_BS = q_IB*
  const float no_attitude[4] = {1.0f, 0.0f, 0.0f, 0.0f};
  for (float use : {0.0f, 1.0f, 2.0f}) {
    const StarAttitudeCase c = star_attitude_case(use, no_attitude, nullptr);
    EXPECT_EQ(c.after.roll, c.before.roll) << "q = 1 0 0 0 is no attitude, EST_STAR_ATT " << use;
    EXPECT_EQ(c.after.yaw, c.before.yaw) << use;
  }
  const StarAttitudeCase off = star_attitude_case(0.0f, q_bs, nullptr);
  EXPECT_EQ(off.after.roll, off.before.roll);
  EXPECT_EQ(off.after.yaw, off.before.yaw);
  const StarAttitudeCase heading = star_attitude_case(1.0f, q_bs, nullptr);
  EXPECT_NEAR(heading.after.roll, heading.before.roll, 1e-6f) << "the heading alone";
  EXPECT_GT(heading.after.yaw - heading.before.yaw, 0.0f);
  EXPECT_LT(heading.after.yaw - heading.before.yaw, 0.2f * 0.0873f + 1e-5f) << "at most max_gain of the error";
  const StarAttitudeCase full = star_attitude_case(2.0f, q_bs, nullptr);
  EXPECT_GT(full.after.roll - full.before.roll, 0.0f);
  EXPECT_LT(full.after.roll - full.before.roll, 0.2f * 0.0349f);
  // A fix whose covariance says 1 rad about every axis barely counts.
  const float wide[6] = {1.0f, 0.0f, 0.0f, 1.0f, 0.0f, 1.0f};
  const StarAttitudeCase doubtful = star_attitude_case(2.0f, q_bs, wide);
  EXPECT_LT(doubtful.after.roll - doubtful.before.roll, 1e-3f * (full.after.roll - full.before.roll) + 1e-7f);
  EXPECT_LT(doubtful.after.yaw - doubtful.before.yaw, 1e-3f * (full.after.yaw - full.before.yaw) + 1e-7f);
}

// Flight control from its parameters: arming is refused until the estimate has converged, MANUAL spins
// the motors with the throttle, and an armed vehicle that sits still on the ground is detected landed.
TEST(FlightControl, ArmsFliesTheSticksAndDetectsTheGround) {
  quad::fw::Params params;
  params.set(quad::fw::kFsRcEnable, 0.0f);
  quad::fw::FlightControl control;
  ASSERT_EQ(control.configure(params), nullptr);
  quad::fw::ModeInputs in;
  in.sensors_healthy = true;
  EXPECT_FALSE(control.command(quad::fw::Command::kArm, in).accepted) << "estimator not converged";
  in.estimator_converged = in.estimator_healthy = true;
  const quad::fw::Transition t = control.command(quad::fw::Command::kArm, in);
  ASSERT_TRUE(t.accepted && t.changed);
  control.enter_mode(t.from, t.to, Vec3{}, 0.0f);
  ASSERT_EQ(control.mode(), quad::fw::FlightMode::kManual);

  quad::ctrl::RcSticks sticks;
  sticks.throttle = 1500;
  control.set_sticks(sticks, 0);
  FrameSchedule schedule;
  schedule.configure(100.0f);
  quad::ctrl::VehicleState s;
  s.q = quad::Quat::identity();
  control.step(s, 0.01f, schedule.next(0.01f, false));
  for (float m : control.motors()) EXPECT_GT(m, 0.1f) << "half throttle spins every motor";

  sticks.throttle = 1000;
  control.set_sticks(sticks, 10000);
  for (int i = 0; i < 200; ++i) {
    control.step(s, 0.01f, schedule.next(0.01f, false));
    control.detect_landing(0.01f, 0.0f);
  }
  EXPECT_TRUE(control.landed()) << "no thrust, no vertical speed";
}

}  // namespace
