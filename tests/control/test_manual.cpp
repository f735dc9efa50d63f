// Manual (RC) flight, thesis sec. 6.1.4 and eq. 6.2.
#include <gtest/gtest.h>

#include <cmath>

#include "eigen_oracle.h"
#include "quad/control/manual.h"

namespace {

using quad::ctrl::ManualControl;
using quad::ctrl::ManualParams;
using quad::ctrl::RcSticks;

TEST(Manual, StickMapping) {
  EXPECT_EQ(quad::ctrl::stick_to_unit(1500, 20), 0.0f);
  EXPECT_EQ(quad::ctrl::stick_to_unit(1520, 20), 0.0f);
  EXPECT_EQ(quad::ctrl::stick_to_unit(1480, 20), 0.0f);
  EXPECT_GT(quad::ctrl::stick_to_unit(1521, 20), 0.0f);
  EXPECT_EQ(quad::ctrl::stick_to_unit(2000, 20), 1.0f);
  EXPECT_EQ(quad::ctrl::stick_to_unit(1000, 20), -1.0f);
  EXPECT_EQ(quad::ctrl::stick_to_unit(2100, 20), 1.0f);
  EXPECT_NEAR(quad::ctrl::stick_to_unit(1760, 20), 0.5f, 1e-6f);
  EXPECT_EQ(quad::ctrl::throttle_to_unit(1000), 0.0f);
  EXPECT_EQ(quad::ctrl::throttle_to_unit(950), 0.0f);
  EXPECT_NEAR(quad::ctrl::throttle_to_unit(1500), 0.5f, 1e-6f);
  EXPECT_EQ(quad::ctrl::throttle_to_unit(2000), 1.0f);
}

// Full right roll and pulled-back pitch give the maximum angles; Q_d agrees with eq. 6.2 evaluated by
// Eigen (yaw, then pitch, then roll).
TEST(Manual, AttitudeFromSticksMatchesEquation62) {
  ManualParams p;
  ManualControl manual(p);
  manual.reset(0.8f);
  const struct {
    uint16_t roll, pitch;
  } cases[] = {{2000, 1500}, {1500, 1000}, {1000, 2000}, {1800, 1300}, {1500, 1500}};
  for (const auto& c : cases) {
    ASSERT_TRUE(manual.update(RcSticks{c.roll, c.pitch, 1500, 1400}, 0.01f));
    const double roll = p.max_angle * quad::ctrl::stick_to_unit(c.roll, p.dead_band);
    const double pitch = p.max_angle * quad::ctrl::stick_to_unit(c.pitch, p.dead_band);
    const Eigen::Quaterniond oracle = Eigen::AngleAxisd(0.8, Eigen::Vector3d::UnitZ()) *
                                      Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                                      Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
    EXPECT_LT(quad_test::rotation_distance(oracle, quad_test::to_eigen(manual.command().q_d)), 2e-6);
    EXPECT_NEAR(quad::norm(manual.command().q_d), 1.0f, 1e-6f);
  }
  // Signs: roll stick right -> right side down; pitch stick forward (< 1500) -> nose down.
  ASSERT_TRUE(manual.update(RcSticks{2000, 1500, 1500, 1400}, 0.01f));
  EXPECT_NEAR(quad::to_euler(manual.command().q_d).roll, p.max_angle, 1e-5f);
  ASSERT_TRUE(manual.update(RcSticks{1500, 1000, 1500, 1400}, 0.01f));
  EXPECT_NEAR(quad::to_euler(manual.command().q_d).pitch, -p.max_angle, 1e-5f);
  EXPECT_GT(quad::rotate(manual.command().q_d, {1.0f, 0.0f, 0.0f}).z, 0.0f);
}

// The yaw stick is a rate: one second at full right stick turns the heading by max_yaw_rate, releasing
// the stick holds the heading, and the heading wraps through +-180 deg.
TEST(Manual, YawStickIsARateIntegratedIntoHeading) {
  ManualParams p;
  ManualControl manual(p);
  manual.reset(0.0f);
  for (int i = 0; i < 100; ++i) ASSERT_TRUE(manual.update(RcSticks{1500, 1500, 2000, 1300}, 0.01f));
  EXPECT_NEAR(manual.heading(), p.max_yaw_rate, 1e-4f);
  EXPECT_NEAR(quad::to_euler(manual.command().q_d).yaw, p.max_yaw_rate, 1e-4f);
  for (int i = 0; i < 500; ++i) ASSERT_TRUE(manual.update(RcSticks{1500, 1500, 1505, 1300}, 0.01f));
  EXPECT_NEAR(manual.heading(), p.max_yaw_rate, 1e-4f);
  for (int i = 0; i < 200; ++i) ASSERT_TRUE(manual.update(RcSticks{1500, 1500, 2000, 1300}, 0.01f));
  EXPECT_NEAR(manual.heading(), quad::wrap_pi(3.0f * p.max_yaw_rate), 1e-3f);  // 270 deg = -90 deg
  // Yaw stick left turns the other way, over a long time without drift of the unit pair.
  for (int i = 0; i < 30000; ++i) ASSERT_TRUE(manual.update(RcSticks{1500, 1500, 1000, 1300}, 0.01f));
  EXPECT_NEAR(quad::norm(manual.command().q_d), 1.0f, 1e-5f);
}

TEST(Manual, ResetWrapsAnyHeading) {
  ManualControl manual;
  manual.reset(-100.0f);
  EXPECT_NEAR(manual.heading(), std::remainder(-100.0, 2.0 * M_PI), 1e-4);
  manual.reset(1e10f);  // absurd but finite: must terminate with a valid heading
  EXPECT_LE(std::abs(manual.heading()), M_PI + 1e-6);
  manual.reset(NAN);
  EXPECT_EQ(manual.heading(), 0.0f);
}

TEST(Manual, ThrottleToThrust) {
  ManualParams p;
  ManualControl manual(p);
  manual.reset(0.0f);
  ASSERT_TRUE(manual.update(RcSticks{1500, 1500, 1500, 1000}, 0.01f));
  EXPECT_EQ(manual.command().thrust, 0.0f);
  ASSERT_TRUE(manual.update(RcSticks{1500, 1500, 1500, 1500}, 0.01f));
  EXPECT_NEAR(manual.command().thrust, 0.5f * p.max_thrust, 1e-4f);
  ASSERT_TRUE(manual.update(RcSticks{1500, 1500, 1500, 2000}, 0.01f));
  EXPECT_NEAR(manual.command().thrust, p.max_thrust, 1e-4f);
}

TEST(Manual, ImplausiblePulsesAreRejectedAndTheCommandHeld) {
  ManualControl manual;
  manual.reset(0.0f);
  ASSERT_TRUE(manual.update(RcSticks{1700, 1500, 1500, 1500}, 0.01f));
  const quad::Quat before = manual.command().q_d;
  EXPECT_FALSE(manual.update(RcSticks{0, 1500, 1500, 1500}, 0.01f));
  EXPECT_FALSE(manual.update(RcSticks{1500, 1500, 2500, 1500}, 0.01f));
  EXPECT_EQ(manual.command().q_d.x, before.x);
  EXPECT_EQ(manual.command().thrust, manual.params().max_thrust * 0.5f);
}

TEST(Manual, ReversedChannels) {
  ManualParams p;
  p.reverse_pitch = true;
  ManualControl manual(p);
  manual.reset(0.0f);
  ASSERT_TRUE(manual.update(RcSticks{1500, 1000, 1500, 1500}, 0.01f));
  EXPECT_NEAR(quad::to_euler(manual.command().q_d).pitch, p.max_angle, 1e-5f);
}

TEST(Manual, ValidationNamesTheBadField) {
  ManualParams p;
  EXPECT_EQ(quad::ctrl::validate(p), nullptr);
  p.max_angle = 1.0f;  // 57 deg
  EXPECT_STREQ(quad::ctrl::validate(p), "max_angle");
  p = ManualParams{};
  p.max_pulse = 1900;
  EXPECT_STREQ(quad::ctrl::validate(p), "max_pulse");
}

}  // namespace
