// Standing on the ground (quad/estimation/ground_hold.h and PositionFilterCore::fuse_still): when the
// vehicle counts as still, that the pseudo-measurements are eq. 8.11b's update (against Eigen's Kalman
// update in double), that they hold a dead-reckoning filter still for 30 s where it would otherwise run
// away, and that the next fix is then an ordinary update. The EKF's counterpart (ErrorStateEkf::
// fuse_position_hold, DelayedEkfCore's still increments): the update against Eigen's in double, and the
// floor's height and the position where it came to rest held for 30 s.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include <Eigen/Dense>

#include "quad/estimation/delayed_ekf.h"
#include "quad/estimation/ground_hold.h"
#include "quad/estimation/position_filter.h"

namespace {

using quad::Vec3;
using quad::est::FixResult;
using quad::est::GroundHold;
using quad::est::GroundHoldParams;
using quad::est::PositionFilterParams;

constexpr float kG = 9.80665f;
constexpr float kDt = 0.01f;
constexpr uint32_t kStepUs = 10000;
using Filter = quad::est::PositionFilter<quad::est::history_length(100)>;

TEST(GroundHold, HoldsAfterTheStillTimeOnlyOnTheGround) {
  GroundHold g;
  g.configure(GroundHoldParams{0.1f, 0.5f, 0.5f});
  const Vec3 rest{0.0f, 0.0f, -kG};
  int started = 0, first_hold = -1;
  for (int i = 0; i < 100; ++i) {
    if (g.update(true, Vec3{0.01f, -0.02f, 0.0f}, rest, kDt) && first_hold < 0) first_hold = i;
    if (g.started()) ++started;
  }
  // 0.5 s of still samples at 100 Hz (the 50th sample completes it; float sums land on either side).
  EXPECT_GE(first_hold, 48);
  EXPECT_LE(first_hold, 50);
  EXPECT_EQ(started, 1);
  // Off the ground (the land detector says flying) nothing is held, and the still time starts again
  // from the ground on (a steady descent is as still as standing to an IMU).
  EXPECT_FALSE(g.update(false, Vec3{}, rest, kDt));
  EXPECT_FALSE(g.still());
  int again = 0;
  while (!g.update(true, Vec3{}, rest, kDt) && again < 100) ++again;
  EXPECT_GE(again, 48);
  EXPECT_LE(again, 50);
  EXPECT_TRUE(g.started());
}

TEST(GroundHold, MovingTurningOrFallingIsNotStill) {
  GroundHold g;
  g.configure(GroundHoldParams{0.1f, 0.5f, 0.5f});
  auto holds_after = [&](const Vec3& w, const Vec3& a) {
    g.update(true, Vec3{0.2f, 0.0f, 0.0f}, Vec3{0.0f, 0.0f, -kG}, kDt);  // a break first
    bool held = false;
    for (int i = 0; i < 200; ++i) held = g.update(true, w, a, kDt);
    return held;
  };
  EXPECT_TRUE(holds_after(Vec3{0.05f, 0.05f, 0.05f}, Vec3{0.3f, -0.2f, -kG + 0.2f}));
  EXPECT_FALSE(holds_after(Vec3{0.0f, 0.0f, 0.11f}, Vec3{0.0f, 0.0f, -kG}));  // turning at 6.3 deg/s
  // Less than hover thrust in the air (LAND_THR_FRAC 0.9): the specific force is 0.9 g.
  EXPECT_FALSE(holds_after(Vec3{}, Vec3{0.0f, 0.0f, -0.9f * kG}));
  EXPECT_FALSE(holds_after(Vec3{}, Vec3{0.0f, 0.0f, -kG - 0.6f}));  // lifting off
  EXPECT_FALSE(holds_after(Vec3{}, Vec3{0.0f, 0.0f, NAN}));
  // One sample over the bound restarts the still time.
  bool held = holds_after(Vec3{}, Vec3{0.0f, 0.0f, -kG});
  ASSERT_TRUE(held);
  EXPECT_FALSE(g.update(true, Vec3{}, Vec3{0.0f, 0.0f, -kG + 0.7f}, kDt));
  EXPECT_FALSE(g.update(true, Vec3{}, Vec3{0.0f, 0.0f, -kG}, kDt));
}

// The firmware's configuration: thesis Q, horizontal bias states, no z bias (so z has its own class).
PositionFilterParams firmware_params() {
  PositionFilterParams p;
  p.xy_accel_bias = true;
  return p;
}

// Eigen's Kalman update in double for one axis with state (p, v, b): P - P h (h^T P h + r)^-1 h^T P.
struct AxisOracle {
  Eigen::Matrix3d p;
  Eigen::Vector3d x;
  void update(const Eigen::Vector3d& h, double y, double r) {
    const double s = h.dot(p * h) + r;
    const Eigen::Vector3d k = p * h / s;
    x += k * (y - h.dot(x));
    p -= k * h.transpose() * p;
  }
};

TEST(GroundHold, FuseStillIsTheKalmanUpdateOfZeroVelocityThenThePosition) {
  for (const bool z_shares : {false, true}) {
    PositionFilterParams fp = firmware_params();
    fp.z_accel_bias = z_shares;  // the same bias choice on every axis: z shares x's covariance
    Filter kf(fp);
    kf.predict(Vec3{}, 1000000);
    ASSERT_EQ(kf.fuse_position(Vec3{0.1f, -0.2f, -1.0f}, 1000000), FixResult::kInitialized);
    uint32_t t = 1000000;
    for (int i = 0; i < 50; ++i) kf.predict(Vec3{0.05f, -0.03f, 0.2f}, t += kStepUs);
    const Vec3 hold{0.12f, -0.18f, -0.97f};
    AxisOracle o[3];
    for (int i = 0; i < 3; ++i) {
      const quad::est::AxisCovariance& c = kf.covariance(i);
      o[i].p << c.pp, c.pv, c.pb, c.pv, c.vv, c.vb, c.pb, c.vb, c.bb;
      o[i].x << kf.position()[i], kf.velocity()[i], kf.accel_bias()[i];
      // The bias state's variance is zero on an axis without one: the update leaves b alone there.
      o[i].update(Eigen::Vector3d(0, 1, 0), 0.0, 0.01 * 0.01);
      o[i].update(Eigen::Vector3d(1, 0, 0), hold[i], 0.02 * 0.02);
    }
    ASSERT_TRUE(kf.fuse_still(hold, 0.02f, 0.01f));
    for (int i = 0; i < 3; ++i) {
      const quad::est::AxisCovariance& c = kf.covariance(i);
      EXPECT_NEAR(kf.position()[i], o[i].x[0], 1e-6) << "axis " << i << " shares " << z_shares;
      EXPECT_NEAR(kf.velocity()[i], o[i].x[1], 1e-6) << "axis " << i;
      EXPECT_NEAR(kf.accel_bias()[i], o[i].x[2], 1e-5) << "axis " << i;
      // P - w w^T / S in float cancels: its error is float epsilon times the prior's entries (up to 1).
      EXPECT_NEAR(c.pp, o[i].p(0, 0), 1e-6) << "axis " << i;
      EXPECT_NEAR(c.pv, o[i].p(0, 1), 1e-6) << "axis " << i;
      EXPECT_NEAR(c.vv, o[i].p(1, 1), 1e-6) << "axis " << i;
      EXPECT_NEAR(c.bb, o[i].p(2, 2), 1e-6) << "axis " << i;
    }
  }
}

// 30 s standing still after a fix, dead-reckoning on an input with a tilt error of 0.5 deg (0.085 m/s^2)
// and a vertical accelerometer error of 0.1 m/s^2, a fix every 33 ms before; then a fix again.
TEST(GroundHold, HoldsTheEstimateStillForThirtySecondsAndTheNextFixIsAnUpdate) {
  const Vec3 u_error{0.085f, -0.06f, 0.1f};
  const Vec3 truth{0.3f, -0.4f, -0.13f};
  for (const bool hold : {false, true}) {
    Filter kf(firmware_params());
    uint32_t t = 1000000;
    kf.predict(Vec3{}, t);
    for (int i = 0; i < 300; ++i) {
      t += kStepUs;
      kf.predict(u_error, t);
      if (i % 3 == 0) kf.fuse_position(truth, t - 40000);
    }
    GroundHold g;
    g.configure(GroundHoldParams{});
    // Still from the last fix on: the hold begins after the still time, the first still measurement
    // when the last fix has left the history window (250 ms).
    Vec3 start = kf.position();
    float moved = 0.0f;
    int still_fused = 0;
    for (int i = 0; i < 3000 + 50; ++i) {
      t += kStepUs;
      kf.predict(u_error, t);
      if (hold && g.update(true, Vec3{}, Vec3{0.0f, 0.0f, -kG}, kDt)) {
        if (g.started()) g.set_reference(kf.position());
        if (kf.fuse_still(g.reference(), 0.01f, 0.01f) && ++still_fused == 1) start = kf.position();
      }
      if (i >= 50) moved = quad::maxf(moved, quad::norm(kf.position() - start));
    }
    std::printf("[figure] 30 s still, input error (%.3f, %.3f, %.3f) m/s^2: estimate moved %.4f m %s the hold\n",
                u_error.x, u_error.y, u_error.z, moved, hold ? "with" : "without");
    if (!hold) {
      EXPECT_GT(moved, 10.0f);
      continue;
    }
    EXPECT_LT(moved, 0.02f);
    EXPECT_LT(quad::norm(kf.velocity()), 0.005f);
    EXPECT_LT(std::sqrt(kf.covariance(0).pp), 0.05f);
    // From the hold's start on (its still time, 0.5 s, outlasts the last fix's history window).
    EXPECT_EQ(still_fused, 3000);
    // A fix captured before the last still measurement is refused; after a lift-off (0.1 s without the
    // hold) one 40 ms late at the true position is fused through the gate, no reset.
    const uint32_t resets = kf.health().resets;
    EXPECT_EQ(kf.fuse_position(truth, t - 20000), FixResult::kRejectedOutOfOrder);
    for (int i = 0; i < 10; ++i) kf.predict(u_error, t += kStepUs);
    EXPECT_EQ(kf.fuse_position(truth, t - 40000), FixResult::kFused);
    EXPECT_EQ(kf.health().resets, resets);
    EXPECT_LT(quad::norm(kf.position() - truth), 0.02f);
  }
}

TEST(GroundHold, FuseStillWaitsForTheFilterAndForAFixInProgress) {
  Filter kf(firmware_params());
  EXPECT_FALSE(kf.fuse_still(Vec3{}, 0.01f, 0.01f));  // not initialised
  kf.predict(Vec3{}, 1000000);
  kf.initialize_at(Vec3{1.0f, 2.0f, -0.13f});
  EXPECT_TRUE(kf.initialized());
  EXPECT_EQ(kf.position().z, -0.13f);
  EXPECT_EQ(kf.queue_fix(Vec3{1.0f, 2.0f, -0.13f}, 1000000), FixResult::kPending);
  EXPECT_FALSE(kf.fuse_still(Vec3{1.0f, 2.0f, -0.13f}, 0.01f, 0.01f));
  EXPECT_EQ(kf.advance_fix(), FixResult::kPending);
  EXPECT_FALSE(kf.fuse_still(Vec3{1.0f, 2.0f, -0.13f}, 0.01f, 0.01f));
  // Initialised at the ground, the first fix is an ordinary update, not a reset.
  EXPECT_EQ(kf.advance_fix(), FixResult::kFused);
  EXPECT_EQ(kf.health().resets, 0u);
  // A fix in the history window (26 entries, 250 ms) holds the estimate itself: no still measurement
  // until it has left it.
  uint32_t t = 1000000;
  for (int i = 0; i < 26; ++i) {
    EXPECT_FALSE(kf.fuse_still(Vec3{1.0f, 2.0f, -0.13f}, 0.01f, 0.01f)) << i;
    kf.predict(Vec3{}, t += kStepUs);
  }
  EXPECT_TRUE(kf.fuse_still(Vec3{1.0f, 2.0f, -0.13f}, 0.01f, 0.01f));
}

TEST(GroundHold, FixesThatStartDuringAHoldTakeOver) {
  // Standing still with the hold running when the star comes into view (the station starts late): the
  // first fix, captured before the last still measurement, is refused; the hold then waits and the next
  // fixes are fused, however often the caller asks for the hold.
  Filter kf(firmware_params());
  uint32_t t = 1000000;
  kf.predict(Vec3{}, t);
  const Vec3 ground{0.0f, 0.0f, -0.13f};
  kf.initialize_at(ground);
  for (int i = 0; i < 100; ++i) {
    kf.predict(Vec3{}, t += kStepUs);
    ASSERT_TRUE(kf.fuse_still(ground, 0.01f, 0.01f));
  }
  int fused = 0, refused = 0;
  for (int i = 0; i < 300; ++i) {
    kf.predict(Vec3{}, t += kStepUs);
    if (i % 3 == 0) {
      const FixResult r = kf.fuse_position(Vec3{0.01f, 0.0f, -0.13f}, t - 40000);
      fused += r == FixResult::kFused;
      refused += r == FixResult::kRejectedOutOfOrder;
    }
    kf.fuse_still(ground, 0.01f, 0.01f);
  }
  EXPECT_EQ(refused, 1);
  EXPECT_EQ(fused, 99);
}

}  // namespace

namespace {

// A filter descending at 0.5 m/s with fixes down to 0.4 m, then dead-reckoning with the given vertical
// input error, until the fixes have left the history window (250 ms).
void descend(Filter& kf, float u_error_z, uint32_t* t) {
  *t = 1000000;
  kf.predict(Vec3{}, *t);
  float z = -1.0f;
  for (int i = 0; i < 156; ++i) {  // 0.36 s after the last fix at 0.4 m: down to 0.22 m
    *t += kStepUs;
    z += 0.5f * kDt;
    kf.predict(Vec3{0.0f, 0.0f, u_error_z}, *t);
    if (i % 3 == 0 && z < -0.4f) kf.fuse_position(Vec3{0.0f, 0.0f, z}, *t - 40000);
  }
}

}  // namespace

TEST(GroundHold, TheFloorStopsTheDescentsPositionNotItsVelocity) {
  uint32_t t = 0;
  Filter kf(firmware_params());
  descend(kf, 0.3f, &t);
  ASSERT_FALSE(kf.fixes_arriving());
  const float floor_z = -0.13f;
  EXPECT_FALSE(kf.constrain_above_floor(floor_z));  // still above it
  // Dead-reckoned below the floor: the position goes back onto it, the velocity stays (the touchdown's
  // deceleration, measured by the accelerometer, takes it to zero).
  for (int i = 0; i < 100 && kf.position().z <= floor_z; ++i) kf.predict(Vec3{0.0f, 0.0f, 0.3f}, t += kStepUs);
  ASSERT_GT(kf.position().z, floor_z);
  const Vec3 v = kf.velocity();
  const float pp = kf.covariance(2).pp;
  EXPECT_TRUE(kf.constrain_above_floor(floor_z));
  EXPECT_EQ(kf.position().z, floor_z);
  EXPECT_EQ(kf.velocity().z, v.z);
  EXPECT_GT(v.z, 0.4f);
  EXPECT_EQ(kf.covariance(2).pp, pp);
  // Touchdown: -0.5 m/s in a step; then standing, the position stays on the floor.
  kf.predict(Vec3{0.0f, 0.0f, -v.z / kDt}, t += kStepUs);
  kf.constrain_above_floor(floor_z);
  EXPECT_NEAR(kf.position().z, floor_z, 0.005f);
  // While fixes arrive they hold the estimate: no projection.
  Filter flying(firmware_params());
  descend(flying, 0.0f, &t);
  flying.fuse_position(Vec3{0.0f, 0.0f, -0.05f}, t - 40000);
  EXPECT_TRUE(flying.fixes_arriving());
  EXPECT_FALSE(flying.constrain_above_floor(-0.5f));
}

TEST(GroundHold, AtRestFromTheFirstStillSampleOnTheGroundUntilTheHold) {
  GroundHold g;
  g.configure(GroundHoldParams{0.1f, 0.5f, 0.5f});
  const Vec3 rest{0.0f, 0.0f, -kG};
  EXPECT_FALSE(g.update(false, Vec3{}, rest, kDt));
  EXPECT_FALSE(g.at_rest());  // in the air
  EXPECT_FALSE(g.update(true, Vec3{}, Vec3{0.0f, 0.0f, -2.5f * kG}, kDt));
  EXPECT_FALSE(g.at_rest());  // the touchdown's jolt
  EXPECT_FALSE(g.update(true, Vec3{}, rest, kDt));
  EXPECT_TRUE(g.at_rest());
  int steps = 1;
  while (!g.update(true, Vec3{}, rest, kDt) && steps < 100) {
    EXPECT_TRUE(g.at_rest());
    ++steps;
  }
  EXPECT_TRUE(g.holding());
  EXPECT_FALSE(g.at_rest());  // the hold fuses both
}

TEST(GroundHold, ZeroVelocityAtTouchdownStopsTheDeadReckoning) {
  uint32_t t = 0;
  Filter kf(firmware_params());
  descend(kf, 0.0f, &t);
  // Touched down with 0.14 m/s of vertical velocity error and 0.1 m/s^2 of input error.
  kf.predict(Vec3{0.0f, 0.0f, (0.14f - kf.velocity().z) / kDt}, t += kStepUs);
  const Vec3 at_touchdown = kf.position();
  float moved = 0.0f;
  for (int i = 0; i < 50; ++i) {
    kf.predict(Vec3{0.0f, 0.0f, 0.1f}, t += kStepUs);
    EXPECT_TRUE(kf.fuse_zero_velocity(0.01f));
    moved = quad::maxf(moved, quad::norm(kf.position() - at_touchdown));
  }
  std::printf("[figure] 0.5 s at rest after a touchdown with 0.14 m/s of error: estimate moved %.4f m\n", moved);
  EXPECT_LT(moved, 0.005f);
  EXPECT_LT(quad::absf(kf.velocity().z), 0.01f);
}

namespace {

using quad::Quat;
using quad::est::DelayedEkf;
using quad::est::EkfParams;
using quad::est::ErrorStateEkf;
using quad::est::StarFix;

constexpr int kEkfN = quad::est::kEkfErrorStates;

// A level, still vehicle's IMU sample with an accelerometer error (body FRD = NED here).
void still_sample(quad::est::DelayedEkfCore& ekf, const Vec3& accel_error) {
  ekf.imu(Vec3{}, Vec3{0.0f, 0.0f, -kG} + accel_error, kDt);
}

// An EKF taking fixes as positions only (no star attitude) over the star's floor at floor_down, started
// level at t_us, 0.1 s behind.
void start_over_floor(quad::est::DelayedEkfCore& ekf, float floor_down, uint32_t t_us) {
  EkfParams params;
  params.star_ned = Vec3{};
  params.star_attitude = quad::est::StarAttitudeUse::kNone;
  ekf.set_params(params, 0.1f, false);
  ekf.set_floor(floor_down);
  ekf.reset(Quat::identity(), Vec3{}, Vec3{}, t_us);
}

// The fix of a level vehicle heading north at p_ned (body = NED), the star at the origin.
StarFix level_fix(const Vec3& p_ned, uint32_t capture_us) {
  StarFix fix;
  fix.capture_us = capture_us;
  fix.star_body = Vec3{} - p_ned;
  return fix;
}

}  // namespace

TEST(GroundHold, EkfPositionHoldIsTheKalmanUpdateOfThePosition) {
  ErrorStateEkf ekf;
  ekf.set_params(EkfParams{});
  ekf.reset(Quat::identity(), Vec3{0.1f, -0.2f, -0.3f}, Vec3{0.05f, 0.02f, -0.1f}, Vec3{}, Vec3{});
  // Correlations between position, velocity, attitude and the biases: a second of prediction, tilted.
  for (int i = 0; i < 100; ++i) ekf.predict(Vec3{0.001f, -0.002f, 0.0005f}, Vec3{0.01f, -0.02f, -kG * kDt}, kDt);
  Eigen::Matrix<double, kEkfN, kEkfN> p;
  for (int i = 0; i < kEkfN; ++i)
    for (int j = 0; j < kEkfN; ++j) p(i, j) = ekf.covariance(i, j);
  const quad::est::EkfState before = ekf.state();
  const Vec3 hold{0.12f, -0.18f, -0.13f};
  // Eigen's batch update in double: H = [0 I 0], R = sigma^2 I.
  Eigen::Matrix<double, 3, kEkfN> h = Eigen::Matrix<double, 3, kEkfN>::Zero();
  h.block<3, 3>(0, quad::est::kEkfPos) = Eigen::Matrix3d::Identity();
  const double r = EkfParams{}.hold_position_sigma * EkfParams{}.hold_position_sigma;
  const Eigen::Matrix3d s = h * p * h.transpose() + r * Eigen::Matrix3d::Identity();
  const Eigen::Matrix<double, kEkfN, 3> k = p * h.transpose() * s.inverse();
  const Eigen::Vector3d nu(hold.x - before.p.x, hold.y - before.p.y, hold.z - before.p.z);
  const Eigen::Matrix<double, kEkfN, 1> dx = k * nu;
  const Eigen::Matrix<double, kEkfN, kEkfN> p_after = p - k * h * p;
  ASSERT_EQ(ekf.fuse_position_hold(hold), quad::est::EkfFuse::kFused);
  const quad::est::EkfState& x = ekf.state();
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(x.p[i], before.p[i] + dx(quad::est::kEkfPos + i), 1e-6) << "p " << i;
    EXPECT_NEAR(x.v[i], before.v[i] + dx(quad::est::kEkfVel + i), 1e-5) << "v " << i;
    EXPECT_NEAR(x.accel_bias[i], before.accel_bias[i] + dx(quad::est::kEkfAccelBias + i), 1e-5) << "b_a " << i;
  }
  for (int i = 0; i < kEkfN; ++i)
    for (int j = 0; j < kEkfN; ++j)
      EXPECT_NEAR(ekf.covariance(i, j), p_after(i, j), 1e-6 + 1e-4 * std::abs(p(i, j))) << i << ", " << j;
  EXPECT_EQ(ekf.fuse_position_hold(Vec3{NAN, 0.0f, 0.0f}), quad::est::EkfFuse::kRejectedInvalid);
}

// Fixes put the vehicle 4 cm above the floor it stands on (the dead-reckoned end of a landing); then 30 s
// still with an accelerometer error of (0.05, -0.04, 0.1) m/s^2: on the floor the estimate comes down to
// the floor's height and stays, and stays where it came to rest horizontally; off the floor (still but
// higher than the star's view) the height is held where it came to rest.
TEST(GroundHold, EkfHoldsTheFloorAndWhereItCameToRest) {
  const float floor_down = -0.13f;
  const Vec3 accel_error{0.05f, -0.04f, 0.1f};
  for (const bool on_floor : {true, false}) {
    DelayedEkf<quad::est::history_length(100)> ekf;
    uint32_t t = 1000000;
    start_over_floor(ekf, floor_down, t);
    const Vec3 fixed{0.1f, -0.2f, floor_down - 0.04f};
    for (int i = 0; i < 100; ++i) {
      still_sample(ekf, Vec3{});
      ekf.predict(t += kStepUs, false);
      if (i % 3 == 0) ASSERT_EQ(ekf.queue_fix(level_fix(fixed, t)), quad::est::EkfFixResult::kQueued);
    }
    for (int i = 0; i < 20; ++i) {  // the last fixes taken (0.1 s behind), not yet still
      still_sample(ekf, Vec3{});
      ekf.predict(t += kStepUs, false);
    }
    ASSERT_TRUE(ekf.position_initialized());
    const Vec3 rest = ekf.position();
    ASSERT_NEAR(rest.z, fixed.z, 0.005f);
    float horizontal = 0.0f, vertical_to_floor = 1.0f;
    for (int i = 0; i < 3000; ++i) {
      still_sample(ekf, accel_error);
      ekf.predict(t += kStepUs, true, false, on_floor);
      const Vec3 d = ekf.position() - rest;
      horizontal = quad::maxf(horizontal, std::sqrt(d.x * d.x + d.y * d.y));
      if (i > 100) vertical_to_floor = quad::absf(ekf.position().z - (on_floor ? floor_down : rest.z));
      if (i == 100 || i == 2999)
        std::printf("[figure] EKF still %s, %.1f s: horizontal move %.4f m, height %.4f m from the %s\n",
                    on_floor ? "on the floor" : "above it", 0.01 * (i + 1), horizontal,
                    ekf.position().z - (on_floor ? floor_down : rest.z), on_floor ? "floor" : "rest");
    }
    EXPECT_LT(horizontal, 0.002f) << "on floor " << on_floor;
    EXPECT_LT(vertical_to_floor, 0.002f) << "on floor " << on_floor;
    EXPECT_LT(quad::norm(ekf.velocity()), 0.005f);
    // The accelerometer's error learned while standing (z only: x, y of a level vehicle are its tilt's).
    EXPECT_NEAR(ekf.delayed_state().accel_bias.z, accel_error.z, 0.02f);
  }
}

// The end of a landing without fixes: the last fix 30 cm above the floor, then the fixes stop and the
// vehicle, descending at 0.5 m/s, touches down 0.6 s later; the touchdown's jolt reaches the delayed filter only
// after its 0.1 s delay, so the output (carried ahead of it on the same velocity) would pass through the
// floor. Without fixes neither the output nor the filter goes below the floor; the velocity is kept
// (the jolt, when measured, takes it to zero). While fixes are fused the floor does not apply.
TEST(GroundHold, EkfStaysAboveTheFloorWithoutFixes) {
  const float floor_down = -0.13f;
  DelayedEkf<quad::est::history_length(100)> ekf;
  uint32_t t = 1000000;
  start_over_floor(ekf, floor_down, t);
  const float speed = 0.5f;
  float truth_down = floor_down - 0.9f;
  // Descending at 0.5 m/s with fixes every 30 ms: the filter learns the velocity.
  for (int i = 0; i < 120; ++i) {
    ekf.imu(Vec3{}, Vec3{0.0f, 0.0f, -kG}, kDt);  // a steady descent: level, specific force g
    truth_down += speed * kDt;
    ekf.predict(t += kStepUs, false);
    if (i % 3 == 0) ASSERT_EQ(ekf.queue_fix(level_fix(Vec3{0.0f, 0.0f, truth_down}, t)), quad::est::EkfFixResult::kQueued);
  }
  ASSERT_TRUE(ekf.position_initialized());
  ASSERT_NEAR(ekf.velocity().z, speed, 0.05f);
  ASSERT_LT(truth_down, floor_down - 0.25f);
  // The fixes stop; the estimate dead-reckons on down to the floor and, unconstrained, beyond it.
  float deepest = -1.0f, deepest_filter = -1.0f;
  for (int i = 0; i < 80; ++i) {
    ekf.imu(Vec3{}, Vec3{0.0f, 0.0f, -kG}, kDt);  // a steady descent: level, specific force g
    ekf.predict(t += kStepUs, false);
    deepest = quad::maxf(deepest, ekf.position().z);
    deepest_filter = quad::maxf(deepest_filter, ekf.delayed_state().p.z);
  }
  std::printf("[figure] EKF 0.8 s without fixes at 0.5 m/s down: output %.4f m, filter %.4f m below the floor, "
              "velocity %.3f m/s\n", deepest - floor_down, deepest_filter - floor_down, ekf.velocity().z);
  EXPECT_LE(deepest, floor_down);
  EXPECT_LE(deepest_filter, floor_down);
  EXPECT_NEAR(ekf.position().z, floor_down, 1e-6f);
  EXPECT_GT(ekf.velocity().z, 0.4f);  // kept: only the position is projected

  // A fix below the floor (the floor is the vehicle's standing height: a fix says where it is) is fused.
  for (int i = 0; i < 60; ++i) {
    ekf.imu(Vec3{}, Vec3{0.0f, 0.0f, -kG}, kDt);  // a steady descent: level, specific force g
    ekf.predict(t += kStepUs, false);
    if (i % 3 == 0) ekf.queue_fix(level_fix(Vec3{0.0f, 0.0f, floor_down + 0.02f}, t));
  }
  EXPECT_GT(ekf.position().z, floor_down + 0.01f);
}
