// The cascade wires the pieces and nothing else: its output equals the pieces called by hand, and a bad
// parameter is named and leaves the old parameters in place.
#include <gtest/gtest.h>

#include <cstring>

#include "quad/control/cascade.h"

namespace {

using quad::Quat;
using quad::Vec3;
using quad::ctrl::Cascade;
using quad::ctrl::CascadeParams;

quad::ctrl::VehicleState some_state() {
  quad::ctrl::VehicleState s;
  s.p = {0.4f, -0.3f, -1.2f};
  s.v = {0.1f, 0.2f, -0.05f};
  s.q = quad::normalized(Quat{1.0f, 0.03f, -0.02f, 0.2f});
  s.omega = {0.1f, -0.05f, 0.02f};
  return s;
}

TEST(Cascade, EqualsThePiecesCalledByHand) {
  CascadeParams p;
  p.vehicle.frame = quad::ctrl::Frame::kX;
  p.max_tilt = 0.4f;
  p.attitude.alpha = 5.0f;
  Cascade cascade(p);
  quad::ctrl::PositionSetpoint sp;
  sp.p_d = {1.0f, 0.5f, -1.5f};
  sp.yaw_d = 0.4f;
  const quad::ctrl::VehicleState s = some_state();
  const quad::ctrl::CascadeOutput out = cascade.step(s, sp);

  const Vec3 mu = quad::ctrl::PositionController(p.position).update(sp, s.p, s.v);
  quad::ctrl::ThrustAttitudeParams tp = quad::ctrl::ThrustAttitudeParams::for_vehicle(p.vehicle);
  tp.max_tilt = p.max_tilt;
  const quad::ctrl::AttitudeCommand cmd = quad::ctrl::ThrustAttitude(tp).update(mu, sp.yaw_d);
  const Vec3 tau = quad::ctrl::AttitudeController(p.attitude).update(s.q, s.omega, cmd.q_d);
  const quad::ctrl::MixerOutput m = quad::ctrl::Mixer(p.vehicle).mix(cmd.thrust, tau);
  EXPECT_EQ(std::memcmp(&out.mu_d, &mu, sizeof mu), 0);
  EXPECT_EQ(out.attitude.thrust, cmd.thrust);
  EXPECT_EQ(out.attitude.q_d.z, cmd.q_d.z);
  EXPECT_EQ(out.torque.x, tau.x);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(out.motors.command[i], m.command[i]);

  // From the attitude command on, step_attitude() gives the same motors.
  const quad::ctrl::CascadeOutput att = cascade.step_attitude(s, cmd);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(att.motors.command[i], m.command[i]);
  EXPECT_EQ(quad::norm(att.mu_d), 0.0f);
}

TEST(Cascade, RejectsABadParameterByName) {
  Cascade cascade;
  CascadeParams bad;
  bad.vehicle.mass = -1.0f;
  quad::ctrl::ParamError e = cascade.configure(bad);
  ASSERT_FALSE(e.ok());
  EXPECT_STREQ(e.group, "vehicle");
  EXPECT_STREQ(e.field, "mass");
  EXPECT_EQ(cascade.params().vehicle.mass, 1.4f);  // unchanged

  bad = CascadeParams{};
  bad.position.kv.z = 0.0f;
  e = cascade.configure(bad);
  EXPECT_STREQ(e.group, "position");
  EXPECT_STREQ(e.field, "kv");

  bad = CascadeParams{};
  bad.max_tilt = 2.0f;
  e = cascade.configure(bad);
  EXPECT_STREQ(e.group, "thrust_attitude");
  EXPECT_STREQ(e.field, "max_tilt");

  CascadeParams good;
  good.attitude.alpha = 7.0f;
  EXPECT_TRUE(cascade.configure(good).ok());
  EXPECT_EQ(cascade.params().attitude.alpha, 7.0f);
}

}  // namespace
