// Signs of every force and torque, checked against the independent rigid-body model (rigid_body.h):
// hover thrust balances gravity, each positive torque turns the vehicle the FRD way, and a setpoint to
// the north makes the closed loop pitch nose down and fly north.
#include <gtest/gtest.h>

#include "closed_loop.h"

namespace {

using quad::Vec3;
using quad::ctrl::Frame;
using quad_test::RigidBody;
using quad_test::RigidBodyState;

class Signs : public ::testing::TestWithParam<Frame> {
 protected:
  quad::ctrl::VehicleParams vehicle() const {
    quad::ctrl::VehicleParams v;
    v.frame = GetParam();
    return v;
  }
};

TEST_P(Signs, LevelHoverAtWeightDoesNotAccelerate) {
  const quad::ctrl::VehicleParams v = vehicle();
  const quad::ctrl::Mixer mixer(v);
  const RigidBody body(quad_test::model_of(v));
  const quad::ctrl::MixerOutput out = mixer.mix(v.hover_thrust(), Vec3{});
  const quad_test::RigidBodyRates r = body.rates(RigidBodyState{}, quad_test::commands_of(out));
  EXPECT_LT(r.v_dot.norm(), 1e-5);
  EXPECT_LT(r.w_dot.norm(), 1e-4);
  // And 10 % more thrust accelerates up (-z in NED).
  const quad_test::RigidBodyRates up = body.rates(RigidBodyState{}, quad_test::commands_of(mixer.mix(1.1f * v.hover_thrust(), Vec3{})));
  EXPECT_NEAR(up.v_dot.z(), -0.1 * 9.80665, 1e-4);
}

// Holds a torque demand at hover thrust for 0.3 s and looks at where the body axes went.
TEST_P(Signs, PositiveTorquesTurnTheFrdWay) {
  const quad::ctrl::VehicleParams v = vehicle();
  const quad::ctrl::Mixer mixer(v);
  const RigidBody body(quad_test::model_of(v));
  auto turn = [&](const Vec3& tau) {
    RigidBodyState s;
    const auto u = quad_test::commands_of(mixer.mix(v.hover_thrust(), tau));
    for (int i = 0; i < 300; ++i) body.step(s, u, 1e-3);
    return s.q;
  };
  const Eigen::Quaterniond roll = turn({0.05f, 0.0f, 0.0f});
  EXPECT_GT((roll * Eigen::Vector3d::UnitY()).z(), 0.01) << "positive roll torque must put the right side down";
  EXPECT_GT(quad::to_euler(quad_test::from_eigen(roll)).roll, 0.01f);
  const Eigen::Quaterniond pitch = turn({0.0f, 0.05f, 0.0f});
  EXPECT_LT((pitch * Eigen::Vector3d::UnitX()).z(), -0.01) << "positive pitch torque must raise the nose";
  const Eigen::Quaterniond yaw = turn({0.0f, 0.0f, 0.02f});
  EXPECT_GT((yaw * Eigen::Vector3d::UnitX()).y(), 0.01) << "positive yaw torque must turn the nose right (east)";
}

TEST_P(Signs, SetpointNorthPitchesNoseDownAndFliesNorth) {
  quad::ctrl::CascadeParams p;
  p.vehicle = vehicle();
  quad::ctrl::Cascade cascade(p);
  const RigidBody body(quad_test::model_of(p.vehicle));
  quad::ctrl::PositionSetpoint sp;
  sp.p_d = {1.0f, 0.0f, 0.0f};
  double min_pitch = 0.0;
  const auto log = quad_test::run_closed_loop(body, RigidBodyState{}, 1.0, 100.0, [&](double, const RigidBodyState& x) {
    min_pitch = std::min<double>(min_pitch, quad::to_euler(quad_test::from_eigen(x.q)).pitch);
    return quad_test::commands_of(cascade.step(quad_test::to_vehicle_state(x), sp).motors);
  });
  EXPECT_LT(min_pitch, -0.02);
  EXPECT_GT(log.back().s.v.x(), 0.05);
  EXPECT_LT(std::abs(log.back().s.p.y()), 1e-3);
}

INSTANTIATE_TEST_SUITE_P(Frames, Signs, ::testing::Values(Frame::kPlus, Frame::kX),
                         [](const ::testing::TestParamInfo<Frame>& i) { return i.param == Frame::kX ? "X" : "Plus"; });

}  // namespace
