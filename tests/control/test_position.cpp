// Position controller, thesis eq. 8.20.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "eigen_oracle.h"
#include "quad/control/position_controller.h"

namespace {

using quad::Vec3;
using quad::ctrl::PositionController;
using quad::ctrl::PositionGains;
using quad::ctrl::PositionSetpoint;

TEST(PositionController, DefaultsAreTable81) {
  const PositionGains g;
  EXPECT_EQ(g.kp.x, 3.625f);
  EXPECT_EQ(g.kp.z, 3.625f);
  EXPECT_EQ(g.kv.x, 11.875f);
  EXPECT_EQ(g.kv.y, 11.875f);
  EXPECT_EQ(g.kv.z, 3.5f);
}

TEST(PositionController, OnTheSetpointItCommandsTheFeedForward) {
  PositionSetpoint sp;
  sp.p_d = {1.0f, -2.0f, -1.5f};
  sp.v_d = {0.5f, 0.0f, -0.1f};
  sp.a_d = {0.2f, -0.3f, 0.1f};
  const Vec3 mu = PositionController{}.update(sp, sp.p_d, sp.v_d);
  EXPECT_EQ(mu.x, sp.a_d.x);
  EXPECT_EQ(mu.y, sp.a_d.y);
  EXPECT_EQ(mu.z, sp.a_d.z);
}

// Being north of, east of and below the setpoint (NED) must command acceleration south, west and up;
// moving away must be damped.
TEST(PositionController, PushesBackTowardsTheSetpointAndDamps) {
  const PositionController pc;
  const PositionSetpoint sp;
  const Vec3 mu_p = pc.update(sp, {1.0f, 1.0f, 1.0f}, {});
  EXPECT_LT(mu_p.x, 0.0f);
  EXPECT_LT(mu_p.y, 0.0f);
  EXPECT_LT(mu_p.z, 0.0f);
  const Vec3 mu_v = pc.update(sp, {}, {-1.0f, 2.0f, -0.5f});
  EXPECT_GT(mu_v.x, 0.0f);
  EXPECT_LT(mu_v.y, 0.0f);
  EXPECT_GT(mu_v.z, 0.0f);
}

// Against eq. 8.20 evaluated in double with std::tanh (within the stated tanh_approx accuracy), for
// random states; and the a-priori bound
// |mu_i - a_d,i| < k_p,i + k_v,i however large the errors.
TEST(PositionController, MatchesEquation820AndIsBounded) {
  std::mt19937 rng(4);
  std::normal_distribution<double> n(0.0, 1.0);
  PositionGains g;
  g.kp = {2.0f, 3.0f, 4.0f};
  g.kv = {5.0f, 6.0f, 7.0f};
  const PositionController pc(g);
  for (int k = 0; k < 10000; ++k) {
    const double scale = (k % 2 == 0) ? 1.0 : 100.0;
    PositionSetpoint sp;
    sp.p_d = quad_test::from_eigen(quad_test::random_vector(rng, scale));
    sp.v_d = quad_test::from_eigen(quad_test::random_vector(rng, 1.0));
    sp.a_d = quad_test::from_eigen(quad_test::random_vector(rng, 1.0));
    const Vec3 p = quad_test::from_eigen(quad_test::random_vector(rng, scale));
    const Vec3 v = quad_test::from_eigen(quad_test::random_vector(rng, scale));
    const Vec3 mu = pc.update(sp, p, v);
    for (int i = 0; i < 3; ++i) {
      const double expected = double(sp.a_d[i]) - double(g.kp[i]) * std::tanh(double(p[i]) - double(sp.p_d[i])) -
                              double(g.kv[i]) * std::tanh(double(v[i]) - double(sp.v_d[i]));
      ASSERT_NEAR(mu[i], expected, 1.4e-3 * (g.kp[i] + g.kv[i]) + 1e-5);  // tanh_approx: 1.4e-3
      ASSERT_LE(std::abs(mu[i] - sp.a_d[i]), g.kp[i] + g.kv[i] + 1e-5f);
    }
  }
}

TEST(PositionController, ValidationNamesTheBadField) {
  PositionGains g;
  EXPECT_EQ(quad::ctrl::validate(g), nullptr);
  g.kv.y = -1.0f;
  EXPECT_STREQ(quad::ctrl::validate(g), "kv");
  g = PositionGains{};
  g.kp.z = NAN;
  EXPECT_STREQ(quad::ctrl::validate(g), "kp");
}

}  // namespace
