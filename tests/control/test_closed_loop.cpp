// Closed-loop figures of the control chain against the ideal rigid-body model (rigid_body.h), with the
// thesis gains (table 8.1) and with the tuned gains of docs/control.md: position convergence from a
// 2 m horizontal + 1 m vertical offset, attitude convergence from 170 deg without unwinding, and a
// shaped setpoint move. Each test prints its measured figures.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "closed_loop.h"
#include "quad/control/setpoint_shaper.h"

namespace {

using quad_test::RigidBody;
using quad_test::RigidBodyState;
using quad_test::Sample;

constexpr double kRate = 100.0;  // Hz, the thesis' control rate on the APM 2.5

struct GainSet {
  const char* name;
  quad::ctrl::PositionGains position;
  quad::ctrl::AttitudeGains attitude;
};

GainSet thesis_gains() { return {"thesis", quad::ctrl::PositionGains{}, quad::ctrl::AttitudeGains{}}; }

// The tuned set of docs/control.md: position loop critically damped at 2 rad/s in its linear range
// (k_p = omega^2, k_v = 2 omega), roll/pitch at 15 rad/s with damping ratio 0.9 for the default inertia
// (alpha = 2 I omega^2, Gamma = 2 zeta omega I). Yaw is overdamped (Gamma_z = 1.0 instead of 0.54): its
// torque saturates at about 0.2 N m, and with less damping a large yaw error overshoots.
GainSet tuned_gains() {
  GainSet g{"tuned", {}, {}};
  g.position.kp = {4.0f, 4.0f, 4.0f};
  g.position.kv = {4.0f, 4.0f, 4.0f};
  g.attitude.alpha = 6.75f;
  g.attitude.gamma = {0.405f, 0.405f, 1.0f};
  return g;
}

quad::ctrl::CascadeParams params_for(const GainSet& g, quad::ctrl::Frame frame) {
  quad::ctrl::CascadeParams p;
  p.vehicle.frame = frame;
  p.position = g.position;
  p.attitude = g.attitude;
  return p;
}

struct PositionCase {
  GainSet gains;
  quad::ctrl::Frame frame;
  Eigen::Vector3d offset;  // start minus target, NED
};

class PositionConvergence : public ::testing::TestWithParam<PositionCase> {};

TEST_P(PositionConvergence, ReachesOneCentimetreWithLessThanTenPercentOvershoot) {
  const PositionCase& c = GetParam();
  quad::ctrl::Cascade cascade(params_for(c.gains, c.frame));
  const RigidBody body(quad_test::model_of(cascade.params().vehicle));
  const Eigen::Vector3d target(0.0, 0.0, -1.5);
  RigidBodyState s;
  s.p = target + c.offset;
  quad::ctrl::PositionSetpoint sp;
  sp.p_d = quad_test::from_eigen(target);

  const double duration = 30.0;  // the thesis gains need about 19 s
  const auto log = quad_test::run_closed_loop(body, s, duration, kRate, [&](double, const RigidBodyState& x) {
    return quad_test::commands_of(cascade.step(quad_test::to_vehicle_state(x), sp).motors);
  });

  const double t_settle = quad_test::settling_time(log, target, 0.01);
  double worst_overshoot = 0.0;
  for (int axis = 0; axis < 3; ++axis) worst_overshoot = std::max(worst_overshoot, quad_test::overshoot(log, target, axis));
  double max_tilt_deg = 0.0;
  for (const Sample& x : log) {
    const Eigen::Vector3d body_down = x.s.q * Eigen::Vector3d::UnitZ();
    max_tilt_deg = std::max(max_tilt_deg, std::acos(std::min(1.0, body_down.z())) * 180.0 / M_PI);
  }
  std::printf("[figure] position %s %s offset (%.1f, %.1f, %.1f) m: settling to 1 cm %.2f s, 10 cm %.2f s, "
              "overshoot %.2f %%, max tilt %.1f deg, final error %.2e m\n",
              c.gains.name, c.frame == quad::ctrl::Frame::kX ? "X" : "plus", c.offset.x(), c.offset.y(), c.offset.z(),
              t_settle, quad_test::settling_time(log, target, 0.10), 100.0 * worst_overshoot, max_tilt_deg,
              (log.back().s.p - target).norm());
  EXPECT_GE(t_settle, 0.0) << "did not settle within 1 cm in " << duration << " s";
  EXPECT_LT(worst_overshoot, 0.10);
  EXPECT_LT((log.back().s.p - target).norm(), 0.01);
  EXPECT_LE(max_tilt_deg, 35.0 + 5.0);  // the commanded tilt is limited to 35 deg; the actual lags it a little
}

std::string position_case_name(const ::testing::TestParamInfo<PositionCase>& info) {
  const PositionCase& c = info.param;
  return std::string(c.gains.name) + (c.frame == quad::ctrl::Frame::kX ? "_X" : "_Plus") +
         (c.offset.z() > 0.0 ? "_StartBelow" : "_StartAbove");
}

INSTANTIATE_TEST_SUITE_P(
    GainSets, PositionConvergence,
    ::testing::Values(PositionCase{thesis_gains(), quad::ctrl::Frame::kPlus, {2.0, 0.0, 1.0}},
                      PositionCase{thesis_gains(), quad::ctrl::Frame::kX, {-1.2, 1.6, -1.0}},
                      PositionCase{tuned_gains(), quad::ctrl::Frame::kPlus, {2.0, 0.0, 1.0}},
                      PositionCase{tuned_gains(), quad::ctrl::Frame::kX, {-1.2, 1.6, -1.0}}),
    position_case_name);

struct AttitudeCase {
  GainSet gains;
  Eigen::Vector3d axis;  // of the initial error rotation (body = desired rotated 170 deg about it)
  double angle_deg;
  const char* label;
};

class AttitudeConvergence : public ::testing::TestWithParam<AttitudeCase> {};

// From rest at a large error the vehicle must rotate back along the short way: the error angle never
// grows, the error axis never flips (flipping = passing through 180 deg = the long way), and the error
// ends below one degree.
TEST_P(AttitudeConvergence, TurnsTheShortWayAndConverges) {
  const AttitudeCase& c = GetParam();
  quad::ctrl::Cascade cascade(params_for(c.gains, quad::ctrl::Frame::kPlus));
  const RigidBody body(quad_test::model_of(cascade.params().vehicle));
  const Eigen::Quaterniond q_d(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));  // some heading
  RigidBodyState s;
  s.q = q_d * Eigen::Quaterniond(Eigen::AngleAxisd(c.angle_deg * M_PI / 180.0, c.axis.normalized()));
  quad::ctrl::AttitudeCommand cmd;
  cmd.thrust = cascade.params().vehicle.hover_thrust();
  cmd.q_d = quad_test::from_eigen(q_d);

  const auto log = quad_test::run_closed_loop(body, s, 10.0, kRate, [&](double, const RigidBodyState& x) {
    return quad_test::commands_of(cascade.step_attitude(quad_test::to_vehicle_state(x), cmd).motors);
  });

  // The short-way error: its angle and axis, from the canonical (w >= 0) error quaternion.
  auto error_of = [&](const RigidBodyState& x) {
    Eigen::Quaterniond e = q_d.conjugate() * x.q;
    if (e.w() < 0.0) e.coeffs() = -e.coeffs();
    return Eigen::AngleAxisd(e);
  };
  const Eigen::Vector3d axis0 = error_of(log.front().s).axis();
  const double angle0 = error_of(log.front().s).angle();
  double prev = angle0, max_growth = 0.0, min_axis_dot = 1.0, t_1deg = -1.0, t_5deg = -1.0;
  for (const Sample& x : log) {
    const Eigen::AngleAxisd e = error_of(x.s);
    max_growth = std::max(max_growth, e.angle() - prev);
    prev = e.angle();
    if (e.angle() > 5.0 * M_PI / 180.0) min_axis_dot = std::min(min_axis_dot, e.axis().dot(axis0));
    if (e.angle() > 1.0 * M_PI / 180.0) t_1deg = x.t;
    if (e.angle() > 5.0 * M_PI / 180.0) t_5deg = x.t;
  }
  const double final_deg = error_of(log.back().s).angle() * 180.0 / M_PI;
  std::printf("[figure] attitude %s %s: start %.1f deg, below 5 deg after %.2f s, below 1 deg after %.2f s, "
              "final %.3f deg, largest step growth %.4f deg, min axis alignment %.3f\n",
              c.gains.name, c.label, angle0 * 180.0 / M_PI, t_5deg, t_1deg, final_deg, max_growth * 180.0 / M_PI,
              min_axis_dot);
  EXPECT_NEAR(angle0 * 180.0 / M_PI, 170.0, 1e-6);
  EXPECT_LT(max_growth, 0.1 * M_PI / 180.0) << "the error angle grew: the vehicle turned away";
  // Roll/pitch settle faster than yaw, so an oblique error axis swings towards z; it must never reverse.
  EXPECT_GT(min_axis_dot, 0.0) << "the error axis reversed: the vehicle went the long way round";
  EXPECT_LT(final_deg, 1.0);
}

std::string attitude_case_name(const ::testing::TestParamInfo<AttitudeCase>& info) {
  return std::string(info.param.gains.name) + "_" + info.param.label;
}

INSTANTIATE_TEST_SUITE_P(
    GainSets, AttitudeConvergence,
    ::testing::Values(
        AttitudeCase{thesis_gains(), {1.0, 0.0, 0.0}, 170.0, "Roll170"},
        AttitudeCase{thesis_gains(), {1.0, 0.0, 0.0}, 190.0, "RollMinus170"},
        AttitudeCase{thesis_gains(), {0.6, -0.8, 0.0}, 170.0, "Tilt170"},
        AttitudeCase{thesis_gains(), {0.3, 0.4, 0.866}, 170.0, "Oblique170"},
        AttitudeCase{thesis_gains(), {0.0, 0.0, 1.0}, 170.0, "Yaw170"},
        AttitudeCase{tuned_gains(), {1.0, 0.0, 0.0}, 170.0, "Roll170"},
        AttitudeCase{tuned_gains(), {1.0, 0.0, 0.0}, 190.0, "RollMinus170"},
        AttitudeCase{tuned_gains(), {0.6, -0.8, 0.0}, 170.0, "Tilt170"},
        AttitudeCase{tuned_gains(), {0.3, 0.4, 0.866}, 170.0, "Oblique170"},
        AttitudeCase{tuned_gains(), {0.0, 0.0, 1.0}, 170.0, "Yaw170"}),
    attitude_case_name);

// The same position and attitude figures with what the ideal model leaves out: each rotor lags its
// command (RotorS: 1/80 s up, 1/40 s down) and the controller sees the state one control period late.
class LagAndDelay : public ::testing::TestWithParam<GainSet> {};

TEST_P(LagAndDelay, StillConvergesWithoutOvershootOrUnwinding) {
  const GainSet& g = GetParam();
  quad::ctrl::Cascade cascade(params_for(g, quad::ctrl::Frame::kPlus));
  quad_test::RigidBodyParams model = quad_test::model_of(cascade.params().vehicle);
  model.motor_tau_up = 1.0 / 80.0;
  model.motor_tau_down = 1.0 / 40.0;
  const RigidBody body(model);
  const double hover_command =
      std::sqrt(cascade.params().vehicle.hover_thrust() / (4.0 * cascade.params().vehicle.max_motor_thrust));

  // Position: 2 m north and 1 m below the target.
  const Eigen::Vector3d target(0.0, 0.0, -1.5);
  RigidBodyState s;
  s.p = target + Eigen::Vector3d(2.0, 0.0, 1.0);
  s.rotor.setConstant(hover_command);
  quad::ctrl::PositionSetpoint sp;
  sp.p_d = quad_test::from_eigen(target);
  RigidBodyState seen = s;  // what the controller sees: the state one step ago
  const auto log = quad_test::run_closed_loop(body, s, 30.0, kRate, [&](double, const RigidBodyState& x) {
    const auto u = quad_test::commands_of(cascade.step(quad_test::to_vehicle_state(seen), sp).motors);
    seen = x;
    return u;
  });
  const double t_settle = quad_test::settling_time(log, target, 0.01);
  double worst_overshoot = 0.0;
  for (int axis = 0; axis < 3; ++axis) worst_overshoot = std::max(worst_overshoot, quad_test::overshoot(log, target, axis));

  // Attitude: 170 deg of roll error at hover thrust.
  RigidBodyState a;
  a.q = Eigen::Quaterniond(Eigen::AngleAxisd(170.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()));
  a.rotor.setConstant(hover_command);
  quad::ctrl::AttitudeCommand cmd;
  cmd.thrust = cascade.params().vehicle.hover_thrust();
  RigidBodyState a_seen = a;
  double prev = M_PI, max_growth = 0.0, t_1deg = -1.0;
  const auto alog = quad_test::run_closed_loop(body, a, 5.0, kRate, [&](double t, const RigidBodyState& x) {
    const auto u = quad_test::commands_of(cascade.step_attitude(quad_test::to_vehicle_state(a_seen), cmd).motors);
    a_seen = x;
    const double angle = Eigen::AngleAxisd(x.q).angle();
    const double short_angle = angle > M_PI ? 2.0 * M_PI - angle : angle;
    max_growth = std::max(max_growth, short_angle - prev);
    prev = short_angle;
    if (short_angle > M_PI / 180.0) t_1deg = t;
    return u;
  });
  std::printf("[figure] lag+delay %s: position settling to 1 cm %.2f s, overshoot %.2f %%; roll 170 deg below "
              "1 deg after %.2f s, largest step growth %.4f deg\n",
              g.name, t_settle, 100.0 * worst_overshoot, t_1deg, max_growth * 180.0 / M_PI);
  EXPECT_GE(t_settle, 0.0);
  EXPECT_LT(worst_overshoot, 0.10);
  EXPECT_LT(max_growth, 0.1 * M_PI / 180.0);
  EXPECT_GE(t_1deg, 0.0);
  EXPECT_LT(t_1deg, 4.0);
}

INSTANTIATE_TEST_SUITE_P(GainSets, LagAndDelay, ::testing::Values(thesis_gains(), tuned_gains()),
                         [](const ::testing::TestParamInfo<GainSet>& i) { return std::string(i.param.name); });

// A shaped 3 m move: the vehicle follows the shaper's reference closely and arrives without overshoot.
TEST(ShapedMove, FollowsTheReferenceAndArrivesWithoutOvershoot) {
  quad::ctrl::Cascade cascade(params_for(tuned_gains(), quad::ctrl::Frame::kPlus));
  const RigidBody body(quad_test::model_of(cascade.params().vehicle));
  quad::ctrl::ShaperParams sp_params;
  sp_params.max_speed = 1.0f;
  sp_params.max_accel = 1.0f;
  quad::ctrl::SetpointShaper shaper(sp_params);
  const Eigen::Vector3d start(0.0, 0.0, -1.5), target(3.0, 0.0, -1.5);
  shaper.reset(quad_test::from_eigen(start));
  shaper.set_target(quad_test::from_eigen(target));
  RigidBodyState s;
  s.p = start;
  quad::ctrl::PositionSetpoint sp;
  double worst_tracking = 0.0;
  const auto log = quad_test::run_closed_loop(body, s, 15.0, kRate, [&](double, const RigidBodyState& x) {
    shaper.update(static_cast<float>(1.0 / kRate), sp);
    worst_tracking = std::max(worst_tracking, (x.p - quad_test::to_eigen(sp.p_d)).norm());
    return quad_test::commands_of(cascade.step(quad_test::to_vehicle_state(x), sp).motors);
  });
  const double over = quad_test::overshoot(log, target, 0);
  const double t_settle = quad_test::settling_time(log, target, 0.01);
  std::printf("[figure] shaped 3 m move (1 m/s, 1 m/s^2, tuned gains): worst tracking error %.3f m, "
              "overshoot %.2f %%, settling to 1 cm %.2f s\n",
              worst_tracking, 100.0 * over, t_settle);
  EXPECT_LT(worst_tracking, 0.25);
  EXPECT_LT(over, 0.01);
  EXPECT_GE(t_settle, 0.0);
  EXPECT_LT(t_settle, 10.0);
}

}  // namespace
