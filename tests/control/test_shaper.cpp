// Setpoint shaping: bounded speed and acceleration, consistent derivatives, arrival without overshoot,
// continuity when the target changes mid-move.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "quad/control/setpoint_shaper.h"

namespace {

using quad::Vec3;
using quad::ctrl::PositionSetpoint;
using quad::ctrl::SetpointShaper;
using quad::ctrl::ShaperParams;

constexpr float kDt = 0.01f;

TEST(SetpointShaper, MoveRespectsLimitsAndArrivesWithoutOvershoot) {
  ShaperParams prm;
  prm.max_speed = 1.5f;
  prm.max_accel = 2.0f;
  SetpointShaper shaper(prm);
  const Vec3 start{1.0f, -1.0f, -1.5f}, target{4.0f, 3.0f, -2.5f};  // 5.1 m away
  shaper.reset(start);
  shaper.set_target(target);
  const Vec3 dir = quad::normalized(target - start);
  const float dist = quad::norm(target - start);
  PositionSetpoint sp, prev;
  prev.p_d = start;
  float max_speed = 0.0f, max_accel = 0.0f, max_past = 0.0f, max_off_line = 0.0f;
  int steps = 0;
  for (; steps < 2000 && !shaper.arrived(1e-3f); ++steps) {
    shaper.update(kDt, sp);
    max_speed = std::max(max_speed, quad::norm(sp.v_d));
    max_accel = std::max(max_accel, quad::norm(sp.a_d));
    max_past = std::max(max_past, quad::dot(sp.p_d - target, dir));
    max_off_line = std::max(max_off_line, quad::norm(quad::cross(sp.p_d - start, dir)));
    // p_d' = v_d and v_d' = a_d over the step (trapezoidal / exact for piecewise-constant a).
    ASSERT_NEAR(quad::norm((sp.p_d - prev.p_d) - (sp.v_d + prev.v_d) * (0.5f * kDt)), 0.0f, 1e-5f);
    ASSERT_NEAR(quad::norm((sp.v_d - prev.v_d) - sp.a_d * kDt), 0.0f, 1e-5f);
    prev = sp;
  }
  const float t = steps * kDt;
  const float t_ideal = dist / prm.max_speed + prm.max_speed / prm.max_accel;  // trapezoidal profile
  std::printf("[figure] shaper 5.1 m move (1.5 m/s, 2 m/s^2): arrived within 1 mm after %.2f s (trapezoid "
              "%.2f s), max speed %.3f, max accel %.3f, past the target %.2e m\n",
              t, t_ideal, max_speed, max_accel, max_past);
  EXPECT_TRUE(shaper.arrived(1e-3f));
  EXPECT_LE(max_speed, prm.max_speed * (1.0f + 1e-5f));
  EXPECT_LE(max_accel, prm.max_accel * (1.0f + 1e-5f));
  EXPECT_LT(max_past, 1e-4f);
  EXPECT_LT(max_off_line, 1e-4f);
  EXPECT_LT(t, t_ideal + 1.5f);  // the exponential finish costs a little time, not a lot
  EXPECT_GT(t, t_ideal - 0.05f);
}

// A new target behind the reference mid-move: the velocity changes at most max_accel dt per step, and
// the reference reaches the new target.
TEST(SetpointShaper, RetargetMidMoveStaysContinuous) {
  ShaperParams prm;
  SetpointShaper shaper(prm);
  shaper.reset(Vec3{});
  shaper.set_target({10.0f, 0.0f, 0.0f});
  PositionSetpoint sp, prev;
  for (int i = 0; i < 150; ++i) {
    prev = sp;
    shaper.update(kDt, sp);
  }
  ASSERT_GT(sp.v_d.x, 0.9f);
  shaper.set_target({0.0f, 2.0f, 0.0f});
  for (int i = 0; i < 2000 && !shaper.arrived(1e-3f); ++i) {
    prev = sp;
    shaper.update(kDt, sp);
    ASSERT_LE(quad::norm(sp.v_d - prev.v_d), prm.max_accel * kDt * (1.0f + 1e-4f));
    ASSERT_LE(quad::norm(sp.p_d - prev.p_d), prm.max_speed * kDt * (1.0f + 1e-4f));
  }
  EXPECT_TRUE(shaper.arrived(1e-3f));
}

TEST(SetpointShaper, AtRestOnTargetItHolds) {
  SetpointShaper shaper;
  shaper.reset({1.0f, 2.0f, 3.0f});
  PositionSetpoint sp;
  shaper.update(kDt, sp);
  EXPECT_EQ(sp.p_d.x, 1.0f);
  EXPECT_EQ(quad::norm(sp.v_d), 0.0f);
  EXPECT_EQ(quad::norm(sp.a_d), 0.0f);
  shaper.update(0.0f, sp);  // a zero or bad step does not move it
  shaper.update(NAN, sp);
  EXPECT_EQ(sp.p_d.z, 3.0f);
}

TEST(SetpointShaper, ValidationNamesTheBadField) {
  ShaperParams p;
  EXPECT_EQ(quad::ctrl::validate(p), nullptr);
  p.max_accel = 0.0f;
  EXPECT_STREQ(quad::ctrl::validate(p), "max_accel");
}

}  // namespace
