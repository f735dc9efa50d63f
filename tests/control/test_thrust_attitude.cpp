// Thrust and desired attitude, thesis eq. 8.28-8.37 (corrected per the errata), composed with the yaw.
#include <gtest/gtest.h>

#include <algorithm>
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

// Thrust, desired attitude and applied acceleration equal component by component (the limited flag is
// the caller's to compare: the two forms report it differently at the tilt limit).
::testing::AssertionResult same_command(const AttitudeCommand& got, const AttitudeCommand& want) {
  const float g[] = {got.thrust, got.q_d.w, got.q_d.x, got.q_d.y, got.q_d.z, got.mu_applied.x, got.mu_applied.y, got.mu_applied.z};
  const float w[] = {want.thrust, want.q_d.w, want.q_d.x, want.q_d.y, want.q_d.z, want.mu_applied.x, want.mu_applied.y, want.mu_applied.z};
  const char* names[] = {"thrust", "q_d.w", "q_d.x", "q_d.y", "q_d.z", "mu_applied.x", "mu_applied.y", "mu_applied.z"};
  for (int i = 0; i < 8; ++i) {
    if (!(g[i] == w[i])) return ::testing::AssertionFailure() << names[i] << ": " << g[i] << " vs " << w[i];
  }
  return ::testing::AssertionSuccess();
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

// The limits as first written (eq. 8.28-8.37 with the three limits, float comparisons, no shortcut),
// for the bit-for-bit check below.
AttitudeCommand reference_update(const ThrustAttitudeParams& p, const Vec3& mu_d, float yaw_d, bool* tilt_capped = nullptr) {
  const float tan_max_tilt = tanf(p.max_tilt), min_accel = p.min_thrust / p.mass, max_accel = p.max_thrust / p.mass;
  const float max_accel_sq = max_accel * max_accel;
  AttitudeCommand cmd;
  float a_z = quad::kGravity - mu_d.z, h_x = -mu_d.x, h_y = -mu_d.y;
  bool limited = false;
  if (a_z < min_accel) {
    a_z = min_accel;
    limited = true;
  } else if (a_z > max_accel) {
    a_z = max_accel;
    limited = true;
  }
  float h_sq = h_x * h_x + h_y * h_y;
  const float a_z_sq = a_z * a_z;
  const float tilt_cap = tan_max_tilt * a_z;
  const float h_max_sq = std::min(tilt_cap * tilt_cap, std::max(max_accel_sq - a_z_sq, 0.0f));
  if (tilt_capped) *tilt_capped = h_sq > h_max_sq && !(max_accel_sq - a_z_sq < tilt_cap * tilt_cap);
  if (h_sq > h_max_sq) {
    const float s = sqrtf(h_max_sq / h_sq);
    h_x *= s;
    h_y *= s;
    h_sq = h_max_sq;
    limited = true;
  }
  const float n = sqrtf(h_sq + a_z_sq);
  cmd.thrust = p.mass * n;
  const float k = 1.0f / sqrtf(2.0f * n * (n + a_z));
  // Q_tilt (x) Q_yaw with k cos and k sin formed first, the library's evaluation order.
  const float c = cosf(0.5f * yaw_d), sn = sinf(0.5f * yaw_d);
  const float k_c = k * c, k_s = k * sn;
  cmd.q_d = quad::Quat{(n + a_z) * k_c, h_x * k_s - h_y * k_c, h_x * k_c + h_y * k_s, (n + a_z) * k_s};
  cmd.mu_applied = Vec3{-h_x, -h_y, quad::kGravity - a_z};
  cmd.limited = limited;
  return cmd;
}

// The shortcut for limits 2 and 3 and the comparisons by bit pattern must not change a single bit:
// 200 000 demands per parameter set (tilt limits 10-80 deg, thrust ranges down to barely above the
// weight) spread over every region, many of them right at the shortcut's bounds and at the limits.
// At the tilt limit the closed form (max_tilt's own cosine and sine) replaces the general one: there the
// command agrees to float round-off (asserted below 4e-7, relative for the thrust).
TEST(ThrustAttitude, ShortcutsAreBitIdenticalToTheFullLimits) {
  std::mt19937 rng(830);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const float tilts[] = {10.0f, 35.0f, 60.0f, 80.0f};
  const float max_thrusts[] = {4.0f * 0.88f * quad::kGravity, 1.05f * 1.4f * quad::kGravity, 100.0f};
  int limited = 0, free = 0, tilt_capped_count = 0;
  double worst_q = 0.0, worst_thrust = 0.0, worst_mu = 0.0;
  for (float tilt : tilts) {
    for (float max_thrust : max_thrusts) {
      ThrustAttitudeParams p;
      p.max_tilt = tilt * quad::kDegToRad;
      p.max_thrust = max_thrust;
      ThrustAttitude ta(p);
      const float max_accel = p.max_thrust / p.mass, tan_tilt = tanf(p.max_tilt);
      for (int k = 0; k < 200000; ++k) {
        // Vertical: anywhere, or near 0.5 g (the shortcut's a_z bound) and near the thrust bounds.
        float a_z;
        switch (k % 4) {
          case 0: a_z = 1.5f * max_accel * u(rng); break;
          case 1: a_z = 0.5f * quad::kGravity * (1.0f + 1e-3f * u(rng)); break;
          case 2: a_z = max_accel * (1.0f + 1e-2f * u(rng)); break;
          default: a_z = quad::kGravity * (1.0f + 0.3f * u(rng)); break;
        }
        // Horizontal: around the tilt cap of this a_z, of 0.5 g, or of the thrust cap.
        const float cap = (k % 3 == 0) ? tan_tilt * std::abs(a_z)
                          : (k % 3 == 1) ? tan_tilt * 0.5f * quad::kGravity
                                         : std::sqrt(std::max(max_accel * max_accel - a_z * a_z, 0.0f));
        const float r = cap * (1.0f + ((k / 4) % 2 == 0 ? 1e-5f : 0.3f) * u(rng)), phi = 3.14159f * u(rng);
        const Vec3 mu{r * std::cos(phi), r * std::sin(phi), quad::kGravity - a_z};
        const float yaw = (k % 5 == 0) ? 0.0f : 0.7f;
        bool tilt_capped = false;
        const AttitudeCommand got = ta.update(mu, yaw), want = reference_update(p, mu, yaw, &tilt_capped);
        ASSERT_EQ(got.limited, want.limited) << k;
        if (tilt_capped) {
          ++tilt_capped_count;
          worst_q = std::max({worst_q, double(std::abs(got.q_d.w - want.q_d.w)), double(std::abs(got.q_d.x - want.q_d.x)),
                              double(std::abs(got.q_d.y - want.q_d.y)), double(std::abs(got.q_d.z - want.q_d.z))});
          worst_thrust = std::max(worst_thrust, double(std::abs(got.thrust - want.thrust) / want.thrust));
          worst_mu = std::max(worst_mu, double(quad::norm(got.mu_applied - want.mu_applied)) /
                                            std::max(1.0, double(quad::norm(want.mu_applied))));
          continue;
        }
        ASSERT_TRUE(same_command(got, want)) << k;
        limited += want.limited;
        free += !want.limited;
      }
    }
  }
  std::printf("[figure] thrust/attitude closed form at the tilt limit (%d demands): q_d within %.1e, thrust %.1e "
              "relative, mu_applied %.1e of the general form; all other demands bit-identical\n",
              tilt_capped_count, worst_q, worst_thrust, worst_mu);
  EXPECT_LT(worst_q, 4e-7);
  EXPECT_LT(worst_thrust, 4e-7);
  EXPECT_LT(worst_mu, 4e-7);
  EXPECT_GT(tilt_capped_count, 100000);
  EXPECT_GT(limited, 500000);
  EXPECT_GT(free, 500000);
}

// The in-place form (what Cascade uses) writes every field, whatever the struct held before.
TEST(ThrustAttitude, InPlaceUpdateWritesEveryField) {
  ThrustAttitude ta;
  const Vec3 mus[] = {{0.1f, -0.2f, 0.3f}, {30.0f, -20.0f, 0.0f}, {0.0f, 0.0f, 25.0f}, {NAN, 0.0f, 0.0f}};
  for (int k = 0; k < 4; ++k) {
    AttitudeCommand dirty;
    dirty.thrust = NAN;
    dirty.q_d = quad::Quat{NAN, NAN, NAN, NAN};
    dirty.mu_applied = Vec3{NAN, NAN, NAN};
    dirty.limited = (k % 2 == 0);
    ta.update(mus[k], 0.4f, dirty);
    const AttitudeCommand want = ta.update(mus[k], 0.4f);
    EXPECT_TRUE(same_command(dirty, want)) << k;
    EXPECT_EQ(dirty.limited, want.limited) << k;
  }
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
