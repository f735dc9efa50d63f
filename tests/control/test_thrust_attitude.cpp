// Thrust and desired attitude, thesis eq. 8.28-8.37 (corrected per the errata), composed with the yaw.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "eigen_oracle.h"
#include "quad/control/position_controller.h"
#include "quad/control/thrust_attitude.h"

namespace {

using quad::Vec3;
using quad::ctrl::AttitudeCommand;
using quad::ctrl::ThrustAttitude;
using quad::ctrl::ThrustAttitudeParams;

constexpr double kG = 9.80665;

// Angle between the desired body thrust axis R_d (-e_3) and the direction mu - g e_z (radians).
double thrust_axis_error(const AttitudeCommand& cmd, const Eigen::Vector3d& mu) {
  const Eigen::Vector3d axis = quad_test::to_eigen(cmd.q_d).normalized() * Eigen::Vector3d(0.0, 0.0, -1.0);
  const Eigen::Vector3d want = mu - Eigen::Vector3d(0.0, 0.0, kG);
  return std::atan2(axis.cross(want).norm(), axis.dot(want));
}

double tilt_of(const AttitudeCommand& cmd) {
  const Eigen::Vector3d down = quad_test::to_eigen(cmd.q_d).normalized() * Eigen::Vector3d::UnitZ();
  return std::acos(std::min(1.0, down.z()));
}

TEST(ThrustAttitude, HoverIsLevelAtWeight) {
  ThrustAttitude ta;
  const AttitudeCommand cmd = ta.update(Vec3{}, 0.0f);
  EXPECT_NEAR(cmd.thrust, 1.4f * 9.80665f, 1e-5f);
  EXPECT_NEAR(cmd.q_d.w, 1.0f, 1e-7f);
  EXPECT_NEAR(quad::norm(cmd.q_d.vec()), 0.0f, 1e-7f);
  EXPECT_FALSE(cmd.limited);
}

// 10 000 random mu_d inside the limits: the body thrust axis of Q_d points along mu_d - g e_z, the thrust
// is m ||g e_z - mu_d|| (eq. 8.30), the tilt stays within the limit, and Q_d is Eigen's minimal rotation
// from e_3 to u composed with the yaw.
TEST(ThrustAttitude, ThrustAxisFollowsMuInsideTheLimits) {
  ThrustAttitude ta;
  const ThrustAttitudeParams& p = ta.params();
  const double a_min = p.min_thrust / p.mass, a_max = p.max_thrust / p.mass;
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  double worst_axis = 0.0, worst_thrust = 0.0, worst_tilt = 0.0, worst_q = 0.0;
  for (int k = 0; k < 10000; ++k) {
    const double a_z = a_min + (a_max - a_min) * (0.01 + 0.98 * u01(rng));
    const double h_max = std::min(std::tan(p.max_tilt) * a_z, std::sqrt(a_max * a_max - a_z * a_z));
    const double h = 0.99 * h_max * std::sqrt(u01(rng)), dir = 2.0 * M_PI * u01(rng);
    const Eigen::Vector3d mu(-h * std::cos(dir), -h * std::sin(dir), kG - a_z);
    const double yaw = M_PI * (2.0 * u01(rng) - 1.0);
    const AttitudeCommand cmd = ta.update(quad_test::from_eigen(mu), static_cast<float>(yaw));
    ASSERT_FALSE(cmd.limited) << "mu inside the limits was changed, sample " << k;
    const double n = (Eigen::Vector3d(0.0, 0.0, kG) - mu).norm();
    worst_axis = std::max(worst_axis, thrust_axis_error(cmd, mu));
    worst_thrust = std::max(worst_thrust, std::abs(cmd.thrust - p.mass * n) / (p.mass * n));
    worst_tilt = std::max(worst_tilt, tilt_of(cmd));
    const Eigen::Quaterniond oracle = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), (Eigen::Vector3d(0.0, 0.0, kG) - mu) / n) *
                                      Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
    worst_q = std::max(worst_q, quad_test::rotation_distance(oracle, quad_test::to_eigen(cmd.q_d)));
  }
  std::printf("[figure] desired attitude, 10000 mu_d inside limits: thrust-axis error max %.2e rad, thrust "
              "relative error max %.2e, max tilt %.3f deg (limit 35), |Q_d - Eigen| max %.2e rad\n",
              worst_axis, worst_thrust, worst_tilt * 180.0 / M_PI, worst_q);
  EXPECT_LT(worst_axis, 1e-5);
  EXPECT_LT(worst_thrust, 1e-5);
  EXPECT_LE(worst_tilt, p.max_tilt + 1e-5);
  EXPECT_LT(worst_q, 1e-5);
}

// 10 000 random mu_d anywhere, including far outside (upward specific force, huge horizontal demand):
// the limits hold, the command is finite and unit, and it realises mu_applied exactly.
TEST(ThrustAttitude, LimitsHoldForAnyMu) {
  ThrustAttitude ta;
  const ThrustAttitudeParams& p = ta.params();
  std::mt19937 rng(9);
  double worst_tilt = 0.0;
  int limited = 0;
  for (int k = 0; k < 10000; ++k) {
    const Eigen::Vector3d mu = quad_test::random_vector(rng, (k % 3 == 0) ? 5.0 : 30.0);
    const AttitudeCommand cmd = ta.update(quad_test::from_eigen(mu), 0.5f);
    ASSERT_TRUE(quad::is_finite(cmd.q_d) && quad::is_finite(cmd.thrust));
    ASSERT_NEAR(quad::norm(cmd.q_d), 1.0f, 1e-5f);
    ASSERT_GE(cmd.thrust, p.min_thrust * (1.0f - 1e-5f));
    ASSERT_LE(cmd.thrust, p.max_thrust * (1.0f + 1e-5f));
    ASSERT_LT(thrust_axis_error(cmd, quad_test::to_eigen(cmd.mu_applied)), 1e-5);
    ASSERT_NEAR(cmd.thrust, p.mass * quad::norm(Vec3{0.0f, 0.0f, quad::kGravity} - cmd.mu_applied), 1e-4f);
    worst_tilt = std::max(worst_tilt, tilt_of(cmd));
    limited += cmd.limited ? 1 : 0;
  }
  std::printf("[figure] desired attitude, 10000 mu_d anywhere (%d limited): max tilt %.4f deg (limit 35)\n", limited,
              worst_tilt * 180.0 / M_PI);
  EXPECT_LE(worst_tilt, p.max_tilt + 1e-5);
  EXPECT_GT(limited, 1000);  // the sample really exercised the limits
}

// A commanded downward acceleration beyond free fall would need the thrust to point down: the command
// stays upright at the minimum thrust instead (level, or tilted no more than the limit).
TEST(ThrustAttitude, NeverCommandsTheThrustDownwards) {
  ThrustAttitude ta;
  const AttitudeCommand level = ta.update(Vec3{0.0f, 0.0f, 25.0f}, 0.0f);
  EXPECT_TRUE(level.limited);
  EXPECT_NEAR(level.thrust, ta.params().min_thrust, 1e-4f);
  EXPECT_NEAR(tilt_of(level), 0.0, 1e-6);
  const AttitudeCommand tilted = ta.update(Vec3{3.0f, 0.0f, 25.0f}, 0.0f);
  EXPECT_TRUE(tilted.limited);
  EXPECT_LT(quad::rotate(tilted.q_d, {0.0f, 0.0f, -1.0f}).z, 0.0f);  // thrust axis still points up
  EXPECT_LE(tilt_of(tilted), ta.params().max_tilt + 1e-5);
  EXPECT_GT(quad::rotate(tilted.q_d, {1.0f, 0.0f, 0.0f}).z, 0.0f);  // and leans the way mu_d asks (north)
}

// With altitude at stake the horizontal demand gives way: full thrust stays vertical.
TEST(ThrustAttitude, VerticalHasPriorityAtFullThrust) {
  ThrustAttitude ta;
  const ThrustAttitudeParams& p = ta.params();
  const AttitudeCommand cmd = ta.update(Vec3{-20.0f, 0.0f, quad::kGravity - p.max_thrust / p.mass - 5.0f}, 0.0f);
  EXPECT_TRUE(cmd.limited);
  EXPECT_NEAR(cmd.thrust, p.max_thrust, 1e-3f);
  EXPECT_NEAR(tilt_of(cmd), 0.0, 1e-3);
}

TEST(ThrustAttitude, YawTurnsTheHeadingOnly) {
  ThrustAttitude ta;
  const Vec3 mu{1.0f, -2.0f, 0.5f};
  const AttitudeCommand a = ta.update(mu, 0.0f);
  const AttitudeCommand b = ta.update(mu, 2.0f);
  const Vec3 down_a = quad::rotate(a.q_d, {0.0f, 0.0f, 1.0f});
  const Vec3 down_b = quad::rotate(b.q_d, {0.0f, 0.0f, 1.0f});
  EXPECT_LT(quad::norm(down_a - down_b), 1e-6f);
  // Level: the heading is exactly yaw_d.
  for (float yaw : {-3.0f, -1.0f, 0.3f, 2.5f, 3.1f}) {
    const AttitudeCommand c = ta.update(Vec3{}, yaw);
    EXPECT_NEAR(quad::to_euler(c.q_d).yaw, yaw, 1e-5f);
  }
  // Tilted by 20 deg: the heading error is second order in the tilt (well under a degree).
  const AttitudeCommand t = ta.update(Vec3{2.0f, 2.0f, 0.0f}, 1.0f);
  EXPECT_NEAR(quad::to_euler(t.q_d).yaw, 1.0f, 1.5f * quad::kDegToRad);
}

// A heading far outside (-pi, pi] (a counter that kept integrating) is wrapped, not looped over: exact
// for moderate multiples of 2 pi; for absurd values (float spacing 1024 rad at 1e10) finite and unit.
TEST(ThrustAttitude, HugeHeadingIsWrapped) {
  ThrustAttitude ta;
  EXPECT_NEAR(quad::to_euler(ta.update(Vec3{}, 100.0f).q_d).yaw, std::remainder(100.0, 2.0 * M_PI), 1e-4);
  const AttitudeCommand cmd = ta.update(Vec3{}, 1e10f);
  EXPECT_TRUE(quad::is_finite(cmd.q_d));
  EXPECT_NEAR(quad::norm(cmd.q_d), 1.0f, 1e-6f);
}

// Signs: a setpoint to the north pitches the nose down (negative pitch in FRD), one to the east rolls
// right side down, one above raises the thrust.
TEST(ThrustAttitude, SetpointNorthPitchesNoseDown) {
  quad::ctrl::PositionController pc;
  ThrustAttitude ta;
  quad::ctrl::PositionSetpoint sp;
  sp.p_d = {1.0f, 0.0f, 0.0f};
  const AttitudeCommand north = ta.update(pc.update(sp, Vec3{}, Vec3{}), 0.0f);
  EXPECT_LT(quad::to_euler(north.q_d).pitch, -1.0f * quad::kDegToRad);
  EXPECT_NEAR(quad::to_euler(north.q_d).roll, 0.0f, 1e-6f);
  EXPECT_GT(quad::rotate(north.q_d, {1.0f, 0.0f, 0.0f}).z, 0.0f);  // nose below the horizon (+z is down)

  sp.p_d = {0.0f, 1.0f, 0.0f};
  const AttitudeCommand east = ta.update(pc.update(sp, Vec3{}, Vec3{}), 0.0f);
  EXPECT_GT(quad::to_euler(east.q_d).roll, 1.0f * quad::kDegToRad);
  EXPECT_GT(quad::rotate(east.q_d, {0.0f, 1.0f, 0.0f}).z, 0.0f);  // right side down

  sp.p_d = {0.0f, 0.0f, -1.0f};
  const AttitudeCommand up = ta.update(pc.update(sp, Vec3{}, Vec3{}), 0.0f);
  EXPECT_GT(up.thrust, 1.4f * quad::kGravity * 1.1f);
}

TEST(ThrustAttitude, NonFiniteInputGivesLevelHover) {
  ThrustAttitude ta;
  const AttitudeCommand cmd = ta.update(Vec3{NAN, 0.0f, 0.0f}, 0.0f);
  EXPECT_TRUE(cmd.limited);
  EXPECT_NEAR(cmd.thrust, 1.4f * quad::kGravity, 1e-4f);
  EXPECT_EQ(cmd.q_d.w, 1.0f);
}

TEST(ThrustAttitude, ValidationNamesTheBadField) {
  ThrustAttitudeParams p;
  EXPECT_EQ(quad::ctrl::validate(p), nullptr);
  p.max_tilt = 1.5f;
  EXPECT_STREQ(quad::ctrl::validate(p), "max_tilt");
  p = ThrustAttitudeParams{};
  p.min_thrust = 0.0f;
  EXPECT_STREQ(quad::ctrl::validate(p), "min_thrust");
  p = ThrustAttitudeParams{};
  p.max_thrust = p.min_thrust;
  EXPECT_STREQ(quad::ctrl::validate(p), "max_thrust");
}

}  // namespace
