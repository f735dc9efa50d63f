// Setpoint shaping: bounded speed and acceleration, consistent derivatives, arrival without overshoot,
// continuity when the target changes mid-move.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>

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

// The hold shortcut (update() skips the step when at rest on the target) must change nothing: a shaper
// whose target is moved away and back before every step (which clears the shortcut, so each step is
// computed in full) gives bit-identical setpoints through a move, the arrival, a long hold, a new target and a
// reset, with varying dt.
static bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TEST(SetpointShaper, HoldShortcutIsBitIdenticalToTheFullStep) {
  SetpointShaper fast, full;
  const Vec3 start{0.2f, -0.1f, -1.5f};
  fast.reset(start);
  full.reset(start);
  PositionSetpoint a, b;
  int steps = 0;
  for (int k = 0; k < 3000; ++k) {
    if (k == 200) {
      fast.set_target(Vec3{0.7f, 0.3f, -1.2f});
      full.set_target(Vec3{0.7f, 0.3f, -1.2f});
    }
    if (k == 2000) {
      fast.reset(Vec3{-0.3f, 0.0f, -1.0f});
      full.reset(Vec3{-0.3f, 0.0f, -1.0f});
    }
    const Vec3 target = full.target();
    full.set_target(target + Vec3{1.0f, 0.0f, 0.0f});
    full.set_target(target);
    const float dt = (k % 7 == 3) ? 0.012f : kDt;
    fast.update(dt, a);
    full.update(dt, b);
    const float* fa[] = {&a.p_d.x, &a.p_d.y, &a.p_d.z, &a.v_d.x, &a.v_d.y, &a.v_d.z, &a.a_d.x, &a.a_d.y, &a.a_d.z};
    const float* fb[] = {&b.p_d.x, &b.p_d.y, &b.p_d.z, &b.v_d.x, &b.v_d.y, &b.v_d.z, &b.a_d.x, &b.a_d.y, &b.a_d.z};
    for (int j = 0; j < 9; ++j) ASSERT_TRUE(same_bits(*fa[j], *fb[j])) << "step " << k << " component " << j;
    ++steps;
  }
  EXPECT_EQ(steps, 3000);
  EXPECT_TRUE(fast.arrived(1e-4f));
}

// The shaper as first written (no hold shortcut, the square-root law evaluated at every distance), for
// the bit-for-bit check below.
struct ReferenceShaper {
  ShaperParams prm;
  float linear_dist, dt_ = 0.0f, inv_dt_ = 0.0f;
  Vec3 target, p, v;
  ReferenceShaper(const ShaperParams& q, const Vec3& start)
      : prm(q), linear_dist(q.max_accel / (q.final_gain * q.final_gain)), target(start), p(start) {}
  void update(float dt, PositionSetpoint& sp) {
    Vec3 a;
    if (dt > 0.0f && quad::is_finite(dt) && quad::is_finite(target)) {
      const Vec3 to_target = target - p;
      const float dist_sq = quad::norm_sq(to_target);
      Vec3 v_cmd;
      if (dist_sq > 1e-12f) {
        const float dist = sqrtf(dist_sq);
        const float law = dist <= linear_dist ? prm.final_gain * dist
                                              : sqrtf(2.0f * prm.max_accel * (dist - 0.5f * linear_dist));
        const float speed = std::min(prm.max_speed, law);
        v_cmd = to_target * (speed / dist);
      }
      if (dt != dt_) {
        dt_ = dt;
        inv_dt_ = 1.0f / dt;
      }
      a = quad::sat_delta((v_cmd - v) * inv_dt_, prm.max_accel);
      // Arrival within 0.1 mm when the stop fits in the step (setpoint_shaper.cpp).
      if (dist_sq <= 1e-8f && quad::norm_sq(v) * (inv_dt_ * inv_dt_) <= prm.max_accel * prm.max_accel) {
        a = (Vec3{} - v) * inv_dt_;
        p = target;
        v = Vec3{};
      } else {
        const Vec3 v_next = v + a * dt;
        p += (v + v_next) * (0.5f * dt);
        v = v_next;
      }
    }
    sp.p_d = p;
    sp.v_d = v;
    sp.a_d = a;
  }
};

// The cruise shortcut (max_speed without the square root far from the target) and the hold shortcut
// give bit-identical setpoints to the reference over random moves, retargets and parameter sets,
// including speed/acceleration pairs whose cruise distance lies inside the linear range.
TEST(SetpointShaper, CruiseAndHoldShortcutsAreBitIdenticalToTheReference) {
  std::mt19937 rng(51);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::uniform_real_distribution<float> pos(0.1f, 3.0f);
  int compared = 0;
  for (int run = 0; run < 40; ++run) {
    ShaperParams prm;
    prm.max_speed = pos(rng);
    prm.max_accel = pos(rng) * (run % 4 == 0 ? 5.0f : 1.0f);
    prm.final_gain = (run % 3 == 0) ? 0.5f + pos(rng) : 4.0f;
    SetpointShaper shaper(prm);
    const Vec3 start{u(rng), u(rng), -1.5f + u(rng)};
    shaper.reset(start);
    ReferenceShaper ref(prm, start);
    PositionSetpoint a, b;
    for (int k = 0; k < 1500; ++k) {
      if (k % 500 == 0) {
        const Vec3 target{3.0f * u(rng), 3.0f * u(rng), -1.5f + u(rng)};
        shaper.set_target(target);
        ref.target = target;
      }
      const float dt = (k % 11 == 5) ? 0.004f : 0.01f;
      shaper.update(dt, a);
      ref.update(dt, b);
      const float* fa[] = {&a.p_d.x, &a.p_d.y, &a.p_d.z, &a.v_d.x, &a.v_d.y, &a.v_d.z, &a.a_d.x, &a.a_d.y, &a.a_d.z};
      const float* fb[] = {&b.p_d.x, &b.p_d.y, &b.p_d.z, &b.v_d.x, &b.v_d.y, &b.v_d.z, &b.a_d.x, &b.a_d.y, &b.a_d.z};
      for (int j = 0; j < 9; ++j) ASSERT_TRUE(same_bits(*fa[j], *fb[j])) << "run " << run << " step " << k << " component " << j;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 60000);
}

// After a move the approach ends at rest exactly on the target, and from then on the shaper holds
// (the shortcut that skips the step): without the exact stop the velocity stayed a few 1e-12 m/s and
// every later step was computed in full.
TEST(SetpointShaper, AMoveEndsExactlyAtRestAndHolds) {
  SetpointShaper shaper;
  shaper.reset({0.0f, 0.0f, 0.0f});
  shaper.set_target({0.0f, 0.0f, -1.5f});
  PositionSetpoint sp;
  int first_rest = -1;
  for (int k = 0; k < 6000 && first_rest < 0; ++k) {
    shaper.update(kDt, sp);
    if (sp.v_d.x == 0.0f && sp.v_d.y == 0.0f && sp.v_d.z == 0.0f && k > 10) first_rest = k;
  }
  ASSERT_GE(first_rest, 0) << "never exactly at rest within 60 s";
  EXPECT_LT(first_rest * kDt, 30.0f);
  EXPECT_NEAR(sp.p_d.z, -1.5f, 1e-6f);
  for (int k = 0; k < 100; ++k) {
    shaper.update(kDt, sp);
    ASSERT_EQ(sp.v_d.z, 0.0f);
    ASSERT_EQ(sp.a_d.z, 0.0f);
  }
  EXPECT_TRUE(shaper.holding());
}

TEST(SetpointShaper, ValidationNamesTheBadField) {
  ShaperParams p;
  EXPECT_EQ(quad::ctrl::validate(p), nullptr);
  p.max_accel = 0.0f;
  EXPECT_STREQ(quad::ctrl::validate(p), "max_accel");
}

}  // namespace
